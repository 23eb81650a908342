"""A load generator: N synthetic egos in one process, each a properly joined participant.

The fabric's cost per participant is measured apart from the cost of a Python process per
participant: one Zenoh session, one publisher per ego key, and one timer for all egos. The
timer divides each pose period into `slots` and sends a slice of the egos in each, so the
swarm offers a steady stream (as many independent nodes would) rather than one burst of N
poses every period. Every ego joins, holds its liveliness token and leaves like a real node
(`membership`); poses follow loops around city blocks (`paths`).
"""

from __future__ import annotations

import logging
import resource
import threading
import time
from typing import Annotated

import msgspec
import numpy as np
import zenoh

from carlaverse import messages as m
from carlaverse.config import StrictStruct
from carlaverse.keys import Keys, check_token
from carlaverse.swarm.membership import SwarmMembership
from carlaverse.swarm.paths import BlockLoops
from carlaverse.transport.clock import MonotonicClock, SessionClock
from carlaverse.transport.interest import TiledPublisher

log = logging.getLogger(__name__)

CLOCK_SYNC_PERIOD_S = 2.0  # [s] as a node: keeps the session clock and notices a lost authority
JOIN_RETRY_S = 0.5  # [s] between join rounds while some egos are not admitted

Coordinate = Annotated[float, msgspec.Meta(ge=-1e7, le=1e7)]  # [m] a map position, finite


class SwarmSettings(StrictStruct):
    session: str = "default"
    egos: Annotated[int, msgspec.Meta(ge=1, le=10_000)] = 16
    rate_hz: Annotated[float, msgspec.Meta(gt=0, le=1000)] = 50.0  # [Hz] poses per ego
    # Bounded, so a NaN or an infinity is refused here rather than driving egos nowhere.
    spread_m: Annotated[float, msgspec.Meta(gt=0, le=1e6)] = 1000.0  # [m] side of the square
    block_m: Annotated[float, msgspec.Meta(gt=0, le=1e5)] = 150.0  # [m] street grid spacing
    origin: tuple[Coordinate, Coordinate] = (0.0, 0.0)  # [m] south-west corner of the square
    seed: int = 0
    prefix: str = "swarm"  # ego ids are <prefix>-<index>
    kind: str = "scripted"
    actor_kind: str = "car"
    slots: Annotated[int, msgspec.Meta(ge=1, le=100)] = 10  # sends per pose period
    join_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 2.0
    # Every pose in a frame of its own, as N machines with links of their own send them. One
    # process's egos otherwise share frames, which flatters what receivers pay per pose.
    express: bool = False


class SwarmReport(msgspec.Struct, frozen=True):
    """What a swarm did, for its exit summary."""

    egos: int
    joined: int
    refused: dict[str, str]
    joins: int  # accepted join replies, re-joins after an authority restart included
    left: int  # leaves the authority confirmed
    seconds: float  # [s] publishing time
    poses_sent: int
    poses_per_s: float
    offered_fraction: float  # poses sent / (egos × rate × seconds)
    late_slots: int  # timer slots that started more than one slot late
    send_us_per_pose: float  # [µs] compute + encode + put, per pose
    cpu_fraction: float  # process CPU time / wall time (1.0 = one core)


class Swarm:
    """N egos on one session. `run()` joins them, publishes until stopped, and leaves."""

    def __init__(self, session: zenoh.Session, settings: SwarmSettings) -> None:
        check_token(settings.prefix, "ego id prefix")
        self.session = session
        self.settings = settings
        self.keys = Keys(settings.session)
        self.clock = SessionClock(MonotonicClock())
        self.node_ids = [f"{settings.prefix}-{i}" for i in range(settings.egos)]
        rng = np.random.default_rng(settings.seed)
        self.loops = BlockLoops.scattered(
            settings.egos, settings.spread_m, settings.block_m, rng, settings.origin
        )
        self.members = SwarmMembership(
            session, self.keys, self.node_ids, settings.kind, settings.actor_kind, settings.rate_hz
        )
        self._publishers = [
            TiledPublisher(session, self.keys, node_id, express=settings.express)  # `POSE_QOS`
            for node_id in self.node_ids
        ]
        self._seq = [0] * settings.egos
        self.poses_sent = 0
        self.late_slots = 0
        self._send_s = 0.0  # [s] spent computing, encoding and sending poses
        self._stop = threading.Event()

    def stop(self) -> None:
        self._stop.set()

    def join(self) -> int:
        """Synchronise the clock and ask the authority to admit every ego; how many it took."""
        self._sync(burst=8)
        return self.members.join_missing(self.settings.join_timeout_s)

    def run(self, duration_s: float | None = None) -> SwarmReport:
        """Publish until stop() or `duration_s` (joining whoever is missing), then leave."""
        cpu0, wall0 = _cpu_s(), time.monotonic()
        control = threading.Thread(target=self._control_loop, name="swarm-control", daemon=True)
        control.start()
        started = time.monotonic()
        try:
            self._publish_loop(duration_s)
        finally:
            seconds = time.monotonic() - started
            self._stop.set()
            control.join(timeout=5)
            joined = self.members.joined_count
            self.members.leave_all()
            for publisher in self._publishers:
                publisher.undeclare()
        cpu = (_cpu_s() - cpu0) / max(1e-9, time.monotonic() - wall0)
        return self._report(joined, seconds, cpu)

    def _report(self, joined: int, seconds: float, cpu: float) -> SwarmReport:
        s, sent = self.settings, self.poses_sent
        offered = s.egos * s.rate_hz * seconds
        return SwarmReport(
            egos=s.egos, joined=joined, refused=dict(self.members.refused),
            joins=self.members.joins, left=self.members.left, seconds=round(seconds, 3),
            poses_sent=sent, poses_per_s=round(sent / max(seconds, 1e-9), 1),
            offered_fraction=round(sent / offered, 4) if offered else 0.0,
            late_slots=self.late_slots,
            send_us_per_pose=round(self._send_s / sent * 1e6, 2) if sent else float("nan"),
            cpu_fraction=round(cpu, 3),
        )  # fmt: skip

    # ------------------------------------------------------------ publishing

    def _publish_loop(self, duration_s: float | None) -> None:
        s = self.settings
        slot_s = 1.0 / s.rate_hz / s.slots
        groups = np.array_split(np.arange(s.egos), s.slots)
        local = self.clock.local
        end = None if duration_s is None else local.now() + duration_s
        next_t = local.now()
        k = 0
        while not self._stop.is_set() and (end is None or local.now() < end):
            began = time.perf_counter()
            self._send(groups[k % s.slots])
            self._send_s += time.perf_counter() - began
            k += 1
            next_t += slot_s
            delay = next_t - local.now()
            if delay < -slot_s:  # fell a slot behind: count it, do not burst to catch up
                self.late_slots += 1
                next_t, delay = local.now(), 0.0
            self._stop.wait(max(0.0, delay))

    def _send(self, group: np.ndarray) -> None:
        """One pose for each admitted ego of `group`, each stamped when it is put.

        A node stamps a pose and puts it at once; a swarm puts a slot's poses one after the
        other, and a slot of 26 egos took 0.4 ms (p50) to 3.9 ms (p99, preempted on two
        cores) from its first stamp to its last put. Stamped all at the slot's start, every
        receiver's one-way delay counted that wait, which is the load generator's and no
        node's. So each pose carries its own moment: the group's state, computed once, is
        carried on at its velocity for the microseconds to milliseconds since (on a block's
        straight sides exact; across a corner off by at most speed × that time). The
        moment is read from the local clock: 0.16 µs, where a session-clock reading is 0.8.
        """
        local = self.clock.local.now  # session time moves with it: its offset slews by µs/s
        local0, t0 = local(), self.clock.now()
        state = self.loops.at(t0, group)
        joined, seq, pubs = self.members.joined, self._seq, self._publishers
        pack, version = m.POSE_LAYOUT.pack, m.POSE_LAYOUT_VERSION
        columns = zip(group.tolist(), state.x.tolist(), state.y.tolist(), state.yaw.tolist(),
                      state.vx.tolist(), state.vy.tolist(), strict=True)  # fmt: skip
        for i, x, y, yaw, vx, vy in columns:
            if not joined[i]:
                continue
            seq[i] += 1
            dt = local() - local0
            t, x, y = t0 + dt, x + vx * dt, y + vy * dt
            payload = pack(version, 0, 0, seq[i] & 0xFFFFFFFF, t, x, y, 0.0, 0.0, 0.0, yaw,
                           vx, vy, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # fmt: skip
            pubs[i].put(payload, x, y)
            self.poses_sent += 1

    # ------------------------------------------------------------ membership

    def _control_loop(self) -> None:
        """Keep the clock; notice a lost authority (it no longer knows us) and join again."""
        next_sync = time.monotonic() + CLOCK_SYNC_PERIOD_S
        while not self._stop.wait(JOIN_RETRY_S):
            if time.monotonic() >= next_sync:
                if self._sync(burst=3) is False:
                    log.warning("the authority no longer knows this swarm: joining again")
                    self.members.forget()
                next_sync = time.monotonic() + CLOCK_SYNC_PERIOD_S
            if self.members.joined_count + len(self.members.refused) < self.settings.egos:
                self.members.join_missing(self.settings.join_timeout_s)

    def _sync(self, burst: int) -> bool | None:
        known = None
        for _ in range(burst):
            answer = self.members.sync_clock(self.clock)
            known = answer if answer is not None else known
        return known


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime
