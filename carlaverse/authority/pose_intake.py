"""The authority's pose intake: poses wait in Zenoh's ring, the tick decodes them in batches.

With hundreds of egos at 50 Hz a Python callback per pose costs more than the pose's work:
every sample takes the GIL from the tick thread (which then waits up to the interpreter's
switch interval to get it back). So the pose subscriber has no Python callback: Zenoh puts
samples in a bounded ring (`RING_CAPACITY`; when full the oldest go first, which only
loses poses that newer ones of the same ego supersede), and the tick drains it once per
tick and decodes the whole batch with numpy.

Validation is the same as `messages.decode_pose`, row by row: 64 bytes, the layout version,
every value finite, the time in range; a key that is not `ego/<id>/pose[/<tile>]` of this
key space is refused too. Each bad sample is counted in `drops` under `pose` and dropped;
nothing raises into the tick. A pose's arrival time is the drain's time, at most one tick
after it arrived (the roster only judges it against seconds: skew and despawn timeout).

While the pose digest is heard (`pose_digest`), its relay is the ring's only reader: every
`--digest-ms` it takes what waits (`relay_take`), puts it on `world/@egos` and hands the same
checked rows to the tick, which then takes those instead of draining the ring itself. So the
authority receives each pose once, not once per reader: a second ring would cost a Zenoh
sample and a Python `try_recv` more per pose, under the interpreter's lock the tick needs.
"""

from __future__ import annotations

from collections import deque
from typing import Protocol

from carlaverse import messages as m
from carlaverse.keys import KeySpaceError
from carlaverse.support.tally import Tally
from carlaverse.transport.key_routes import KeyRoutes

RING_CAPACITY = 32_768  # samples: 2.5 s of the session's largest roster (512 egos at 50 Hz)


class Sample(Protocol):
    """What the intake reads of a `zenoh.Sample`."""

    @property
    def key_expr(self) -> object: ...

    @property
    def payload(self) -> object: ...


class PoseRing(Protocol):
    def try_recv(self) -> Sample | None: ...


class PoseIntake:
    """Drains the pose ring: (node id, pose) of every good sample, in arrival order."""

    def __init__(self, ring: PoseRing, drops: Tally) -> None:
        self._ring = ring
        self._drops = drops
        # The pose keys heard, by sender; attached to the session, each is declared to Zenoh
        # so that its samples take a kept route into the ring (`transport.key_routes`).
        self.routes = KeyRoutes()
        # (senders, rows) the digest relay took from the ring, oldest first, for the tick
        self._handed: deque[tuple[list[str], list[bytes]]] = deque()
        # Whether the relay reads the ring now (set by it; the tick then does not). At the
        # moment it starts, the tick may still take a few poses the first digest lacks;
        # when it stops, the next tick drains again, so the tick never loses one.
        self.relayed = False

    def relay_take(self) -> tuple[list[str], list[bytes]]:
        """For the digest relay: the sender and row of every good-sized pose waiting, oldest
        first; the tick gets the same at its next `drain`."""
        taken = checked(*take(self._ring), self._drops, self.routes)
        self._handed.append(taken)
        return taken

    def drain(self, limit: int = RING_CAPACITY) -> list[tuple[str, m.Pose]]:
        """Every pose the relay handed over, then, unless it reads the ring, up to `limit`
        more from the ring."""
        senders: list[str] = []
        rows: list[bytes] = []
        handed = self._handed
        while handed:
            ids, batch = handed.popleft()
            senders += ids
            rows += batch
        if not self.relayed:
            ids, batch = checked(*take(self._ring, limit), self._drops, self.routes)
            senders += ids
            rows += batch
        if not rows:
            return []
        out = []
        for node_id, pose in zip(senders, m.decode_pose_rows(b"".join(rows)), strict=True):
            if pose is None:
                self._drops.add("pose")
            else:
                out.append((node_id, pose))
        return out


def checked(
    keys: list[str], payloads: list[bytes], drops: Tally, routes: KeyRoutes
) -> tuple[list[str], list[bytes]]:
    """(sender, payload) of each sample with a pose key of this key space and the pose's
    size, in order; each other one counted in `drops` under `pose`."""
    senders: list[str] = []
    rows: list[bytes] = []
    known = routes.senders
    for key, payload in zip(keys, payloads, strict=True):
        node_id = known.get(key) or pose_sender(key, routes)
        if node_id is None or len(payload) != m.POSE_SIZE:
            drops.add("pose")
        else:
            senders.append(node_id)
            rows.append(payload)
    return senders, rows


def take(ring: PoseRing, limit: int = RING_CAPACITY) -> tuple[list[str], list[bytes]]:
    """The keys and payloads of up to `limit` samples waiting in `ring`, oldest first."""
    keys: list[str] = []
    payloads: list[bytes] = []
    recv = ring.try_recv
    while len(keys) < limit and (sample := recv()) is not None:
        keys.append(str(sample.key_expr))
        payloads.append(sample.payload.to_bytes())  # type: ignore[attr-defined]
    return keys, payloads


def pose_sender(key: str, routes: KeyRoutes) -> str | None:
    """The node id of a pose key `ego/<id>/pose/<tile>` of this key space, else None."""
    try:
        return routes.sender(key)
    except KeySpaceError:
        return None
