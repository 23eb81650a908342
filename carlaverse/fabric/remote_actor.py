"""Remote actors: turning a jittery stream of pose samples into smooth motion (DESIGN §6).

A `RemoteActor` keeps the recent samples of one peer or NPC and answers "where is it now?".
It renders the past, at `now − delay`, so that there is usually a sample on either side of the
render time to interpolate between (Hermite for position, using the sampled velocities;
shortest arc for angles). The delay tracks what the stream needs: the sender's interval plus
the one-way latency plus a few deviations of both, starting at two send intervals as game
engines do. When samples are late it dead-reckons forward for a bounded time, then holds.
When a late sample shows the extrapolation was off, the error is blended out over
`blend_time_s` instead of teleporting the actor — unless it exceeds `snap_distance_m`.

All times here are session seconds; nothing in this module reads a clock by itself.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from enum import Enum

from carlaverse.config import StrictStruct
from carlaverse.messages import POSE_FLAG_TELEPORT, Pose

_Vec4 = tuple[float, float, float, float]  # x, y, z [m], yaw [rad]


class InterpolationSettings(StrictStruct):
    initial_interval_s: float = 0.02  # assumed send interval before two samples are seen
    initial_intervals: float = 2.0  # the starting delay, in send intervals
    min_delay_s: float = 0.005
    max_delay_s: float = 0.5
    deviations: float = 3.0  # how many mean deviations of latency/interval the delay covers
    margin_s: float = 0.002
    delay_slew: float = 0.1  # max change of the delay per second of time (avoids time warps)
    adaptive: bool = True  # False: keep the starting delay (benchmarks compare both)
    max_extrapolation_s: float = 0.25
    snap_distance_m: float = 4.0
    blend_time_s: float = 0.1
    stale_after_s: float = 1.0
    despawn_timeout_s: float = 3.0
    history_s: float = 2.0  # samples older than render time minus this are dropped


class Phase(Enum):
    WAITING = "waiting"
    INTERPOLATING = "interpolating"
    EXTRAPOLATING = "extrapolating"
    HOLDING = "holding"


@dataclass(frozen=True, slots=True)
class ActorView:
    """Where to draw one remote actor now."""

    actor_id: str
    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float
    vx: float
    vy: float
    vz: float
    phase: Phase
    stale: bool
    render_t: float  # [s] session time shown


def wrap_angle(a: float) -> float:
    """Map an angle to (−π, π]."""
    return a - 2 * math.pi * math.floor((a + math.pi) / (2 * math.pi))


def _hermite(p0: float, v0: float, p1: float, v1: float, s: float, h: float) -> float:
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * h * v0
        + (-2 * s3 + 3 * s2) * p1
        + (s3 - s2) * h * v1
    )


def _ewma(mean: float, dev: float, value: float, gain: float) -> tuple[float, float]:
    err = value - mean
    return mean + gain * err, dev + gain * (abs(err) - dev)


class RemoteActor:
    """The sample buffer and renderer for one remote actor. Not thread-safe: one owner."""

    def __init__(self, actor_id: str, settings: InterpolationSettings, kind: str = "") -> None:
        self.actor_id = actor_id
        self.kind = kind
        self.s = settings
        self._t: list[float] = []
        self._poses: list[Pose] = []
        self.interval_s = settings.initial_interval_s
        self._interval_dev = 0.0
        self._latency = 0.0
        self._latency_dev = 0.0
        self._stats_seeded = False
        self.delay_s = settings.initial_intervals * settings.initial_interval_s
        self._delay_t: float | None = None
        self.last_rx_t = -math.inf
        self._last_render_t: float | None = None
        self._corr = (0.0, 0.0, 0.0, 0.0)  # x, y, z, yaw error still to blend out
        self._corr_t = 0.0
        self.samples_received = 0
        self.snaps = 0

    # ------------------------------------------------------------------ input

    def add(self, pose: Pose, rx_t: float) -> None:
        """Take a sample that arrived at session time `rx_t`."""
        if self._t and pose.t <= self._t[-1] and (pose.t in self._t or pose.t < self._t[0]):
            return  # duplicate or too old to matter
        self.samples_received += 1
        self._observe(pose, rx_t)
        before = self._raw_at_last_render()
        i = bisect.bisect_right(self._t, pose.t)
        self._t.insert(i, pose.t)
        self._poses.insert(i, pose)
        self._correct(before, pose, rx_t)

    def _observe(self, pose: Pose, rx_t: float) -> None:
        latency = rx_t - pose.t
        if self._t and pose.t > self._t[-1]:
            interval = pose.t - self._t[-1]
            if not self._stats_seeded:
                self.interval_s, self._latency, self._stats_seeded = interval, latency, True
            else:
                self.interval_s, self._interval_dev = _ewma(
                    self.interval_s, self._interval_dev, interval, 0.05
                )
        if self._stats_seeded:
            self._latency, self._latency_dev = _ewma(
                self._latency, self._latency_dev, latency, 0.05
            )
        else:
            self._latency = latency
        self.last_rx_t = max(self.last_rx_t, rx_t)

    def _raw_at_last_render(self) -> _Vec4 | None:
        t = self._last_render_t
        if t is None or not self._t or t <= self._t[-1]:
            return None  # interpolation at t is not changed by a newer sample
        p = self._raw(t)[0]
        return p.x, p.y, p.z, p.yaw

    def _correct(self, before: _Vec4 | None, pose: Pose, now: float) -> None:
        if pose.flags & POSE_FLAG_TELEPORT:
            self._corr, self.snaps = (0.0, 0.0, 0.0, 0.0), self.snaps + 1
            return
        if before is None or self._last_render_t is None:
            return
        after = self._raw(self._last_render_t)[0]
        err = (before[0] - after.x, before[1] - after.y, before[2] - after.z,
               wrap_angle(before[3] - after.yaw))  # fmt: skip
        cx, cy, cz, cyaw = self._correction(now)
        total = (cx + err[0], cy + err[1], cz + err[2], cyaw + err[3])
        if math.hypot(total[0], total[1], total[2]) > self.s.snap_distance_m:
            self._corr, self.snaps = (0.0, 0.0, 0.0, 0.0), self.snaps + 1
        else:
            self._corr = total
        self._corr_t = now

    def _correction(self, now: float) -> _Vec4:
        if self._corr == (0.0, 0.0, 0.0, 0.0):
            return self._corr
        k = math.exp(-max(0.0, now - self._corr_t) / self.s.blend_time_s)
        return (self._corr[0] * k, self._corr[1] * k, self._corr[2] * k, self._corr[3] * k)

    # ------------------------------------------------------------------ delay

    def target_delay(self) -> float:
        if not self._stats_seeded or not self.s.adaptive:
            return self.s.initial_intervals * self.interval_s if self.s.adaptive else self.delay_s
        spread = self.s.deviations * (self._latency_dev + self._interval_dev)
        target = self.interval_s + self._latency + spread + self.s.margin_s
        return min(self.s.max_delay_s, max(self.s.min_delay_s, target))

    def _update_delay(self, now: float) -> None:
        if self._delay_t is not None:
            step = self.s.delay_slew * max(0.0, now - self._delay_t)
            target = self.target_delay()
            self.delay_s += max(-step, min(step, target - self.delay_s))
        self._delay_t = now

    # ------------------------------------------------------------------ output

    def is_stale(self, now: float) -> bool:
        return now - self.last_rx_t > self.s.stale_after_s

    def is_expired(self, now: float) -> bool:
        return now - self.last_rx_t > self.s.despawn_timeout_s

    def view(self, now: float) -> ActorView | None:
        """Where to draw the actor at session time `now`; None before the first sample."""
        if not self._t:
            return None
        self._update_delay(now)
        render_t = now - self.delay_s
        self._prune(render_t)
        p, phase = self._raw(render_t)
        self._last_render_t = render_t
        cx, cy, cz, cyaw = self._correction(now)
        return ActorView(
            self.actor_id, p.x + cx, p.y + cy, p.z + cz, p.roll, p.pitch,
            wrap_angle(p.yaw + cyaw), p.vx, p.vy, p.vz, phase, self.is_stale(now), render_t,
        )  # fmt: skip

    def _prune(self, render_t: float) -> None:
        # keep one sample before the render time so interpolation always has a left bracket
        cut = bisect.bisect_left(self._t, render_t - self.s.history_s) - 1
        if cut > 0:
            del self._t[:cut], self._poses[:cut]

    def _raw(self, t: float) -> tuple[Pose, Phase]:
        ts, poses = self._t, self._poses
        i = bisect.bisect_right(ts, t)
        if i == 0:  # a new actor: dead-reckon back from its first sample
            return self._extrapolate(poses[0], max(t - ts[0], -self.s.max_extrapolation_s))
        if i == len(ts):
            return self._extrapolate(poses[-1], t - ts[-1])
        return _interpolate(poses[i - 1], poses[i], t), Phase.INTERPOLATING

    def _extrapolate(self, p: Pose, dt: float) -> tuple[Pose, Phase]:
        phase = Phase.EXTRAPOLATING
        if dt > self.s.max_extrapolation_s:
            dt, phase = self.s.max_extrapolation_s, Phase.HOLDING
        h = 0.5 * dt * dt
        return Pose(
            p.seq, p.t + dt,
            p.x + p.vx * dt + p.ax * h, p.y + p.vy * dt + p.ay * h, p.z + p.vz * dt + p.az * h,
            p.roll + p.wx * dt, p.pitch + p.wy * dt, wrap_angle(p.yaw + p.wz * dt),
            p.vx + p.ax * dt, p.vy + p.ay * dt, p.vz + p.az * dt, p.wx, p.wy, p.wz,
        ), phase  # fmt: skip


def _interpolate(a: Pose, b: Pose, t: float) -> Pose:
    h = b.t - a.t
    s = (t - a.t) / h
    lin = lambda u, v: u + (v - u) * s  # noqa: E731 — tiny local helper on a hot path
    arc = lambda u, v: wrap_angle(u + wrap_angle(v - u) * s)  # noqa: E731
    return Pose(
        b.seq, t,
        _hermite(a.x, a.vx, b.x, b.vx, s, h), _hermite(a.y, a.vy, b.y, b.vy, s, h),
        _hermite(a.z, a.vz, b.z, b.vz, s, h),
        arc(a.roll, b.roll), arc(a.pitch, b.pitch), arc(a.yaw, b.yaw),
        lin(a.vx, b.vx), lin(a.vy, b.vy), lin(a.vz, b.vz),
        lin(a.wx, b.wx), lin(a.wy, b.wy), lin(a.wz, b.wz),
    )  # fmt: skip
