"""The authority's pose digest: every ego's pose relayed many to a message, on `world/@egos`.

A node that hears the whole session (an operator's map, a viewer, a node with no interest
radius) otherwise takes one Zenoh sample per pose, and a sample costs more to receive than
its pose costs to apply: Zenoh's own floor alone is most of the 10 µs a pose may cost
(docs/benchmarks.md, "Receive cost per pose"). The authority receives every pose already;
this relay gathers what arrived in the last `period_s` and puts it as one `PoseDigest`, so
such a node takes dozens of poses per sample, for a delay of about half a period plus one
more hop.

Costs nothing while no one listens: only while the digest's publisher has a matching
subscriber does the relay read the poses, from the authority's own pose ring (`pose_intake`):
it takes what waits there and hands the same rows on to the tick, so the authority receives
each pose once whether or not it relays. It runs on a thread of its own, never in a Zenoh
callback and never in the tick. Rows are passed on exactly as their nodes published them,
after checking their size and key only (a bad one is counted in `drops` under `pose` and left
out): every receiver decodes and checks each row anyway (`PoseDigest.poses`), and tells
present nodes from intruders by presence.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import zenoh

from carlaverse import messages as m
from carlaverse.authority.pose_intake import PoseIntake
from carlaverse.keys import Keys
from carlaverse.support.tally import Tally

log = logging.getLogger(__name__)

DIGEST_PERIOD_S = 0.002  # [s] a digest every 2 ms: ~26 poses each at 256 egos, +1 ms mean delay


class PoseDigestRelay:
    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        intake: PoseIntake,
        drops: Tally,
        new_timestamp: Callable[[], zenoh.Timestamp],
        period_s: float = DIGEST_PERIOD_S,
    ) -> None:
        if period_s <= 0:
            raise ValueError(f"digest period must be > 0 s, got {period_s}")
        self._intake = intake
        self._drops = drops
        self._new_timestamp = new_timestamp
        self.period_s = period_s
        self.digests = 0  # digests put
        self.poses = 0  # poses relayed in them
        self._seq = 0
        # Best effort like the poses themselves: the next digest, a period later, supersedes.
        self._publisher = session.declare_publisher(
            keys.pose_digest, congestion_control=zenoh.CongestionControl.DROP
        )
        self._heard = threading.Event()  # something subscribes to the digest
        self._wake = threading.Event()  # the matching status changed, or close()

        def on_matching(status: zenoh.MatchingStatus) -> None:
            # A Zenoh thread: set flags, nothing that waits.
            (self._heard.set if status.matching else self._heard.clear)()
            self._wake.set()

        self._listener = self._publisher.declare_matching_listener(on_matching)
        # zenoh 1.10's stub types `matching_status` as bool; it is a MatchingStatus at run time.
        if self._publisher.matching_status.matching:  # type: ignore[attr-defined]
            self._heard.set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pose-digest", daemon=True)

    @property
    def relaying(self) -> bool:
        """Whether the relay is taking poses now (someone subscribes to the digest)."""
        return self._intake.relayed

    def start(self) -> PoseDigestRelay:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        self._follow(False)
        self._listener.undeclare()
        self._publisher.undeclare()

    def _run(self) -> None:
        due = time.monotonic()
        while not self._stop.is_set():
            if not self._heard.is_set():  # no one listens: sleep until someone does
                self._follow(False)
                self._wake.wait()
                self._wake.clear()
                due = time.monotonic()
                continue
            # On a cadence, not a sleep after each step: the period is what `period_s` says
            # however long a step took, so a pose waits half a period on average.
            due += self.period_s
            if self._stop.wait(max(0.0, due - time.monotonic())):
                break
            if time.monotonic() - due > self.period_s:
                due = time.monotonic()  # fell behind (a stalled interpreter): do not burst
            try:
                self.step()
            except Exception:  # a bug must not end the relay silently: log, count, go on
                self._drops.add("digest/error")
                log.exception("pose digest step failed")

    def step(self) -> int:
        """Relay what arrived since the last step; the number of poses put."""
        if not self._follow(self._heard.is_set()):
            return 0
        ids, rows = self._intake.relay_take()
        for start in range(0, len(ids), m.DIGEST_MAX_POSES):
            end = start + m.DIGEST_MAX_POSES
            self._seq += 1
            digest = m.PoseDigest(self._seq, ids[start:end], b"".join(rows[start:end]))
            self._publisher.put(m.POSE_DIGEST.encode(digest), timestamp=self._new_timestamp())
            self.digests += 1
        self.poses += len(ids)
        return len(ids)

    def _follow(self, heard: bool) -> bool:
        """Read the pose ring while the digest is heard; leave it to the tick when not."""
        self._intake.relayed = heard
        return heard
