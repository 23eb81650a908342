"""Remote actors: turning a jittery stream of pose samples into smooth motion
(docs/architecture.md §7).

A `RemoteActor` keeps the recent samples of one peer and answers "where to draw it?" in one
of two ways (`InterpolationSettings.render_mode`, chosen per node; the world view asks every
actor of a view at one common time, see `world_view`):

- `past(render_t, now)`: interpolate at a render time behind now, so that there is usually a
  sample on either side (Hermite for position with the sampled velocities, shortest arc for
  angles). The world view picks the render time: now minus the largest delay any stream
  needs, `StreamTiming.target_delay()` — interval + latency + a few deviations of both.
  When samples are late it dead-reckons for a bounded time, then holds; a correction a late
  sample reveals is blended out over `blend_time_s`, one over `snap_distance_m` snaps.
- `present(now)`: project the newest sample to now (see `present.Projector`).

All times here are session seconds; nothing in this module reads a clock by itself.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Literal, TypeVar

from carlaverse.config import StrictStruct
from carlaverse.dead_reckoning import project
from carlaverse.messages import POSE_FLAG_TELEPORT, Pose
from carlaverse.support.angles import wrap_angle
from carlaverse.world.present import Projector

if TYPE_CHECKING:
    import numpy as np

# One actor's coordinate, or a column of them (world/npc_table.py interpolates whole batches).
Coordinate = TypeVar("Coordinate", float, "np.ndarray")

_Vec4 = tuple[float, float, float, float]  # x, y, z [m], yaw [rad]
RenderMode = Literal["past", "present"]


class InterpolationSettings(StrictStruct):
    # `present` draws remote actors where they are now (measured default: docs/benchmarks.md
    # "## WAN"); `past` draws them, all at one time, where they were a delay ago.
    render_mode: RenderMode = "present"
    initial_interval_s: float = 0.02  # assumed send interval before two samples are seen
    initial_intervals: float = 2.0  # the starting delay, in send intervals
    min_delay_s: float = 0.005
    max_delay_s: float = 0.5
    deviations: float = 3.0  # how many mean deviations of latency/interval the delay covers
    margin_s: float = 0.002
    delay_slew: float = 0.1  # max change of the delay per second of time (avoids time warps)
    adaptive: bool = True  # False: keep the starting delay (benchmarks compare both)
    max_extrapolation_s: float = 0.25  # past mode: dead reckoning beyond the newest sample
    max_projection_s: float = 0.5  # present mode: projection beyond the newest sample
    present_blend_s: float = 0.05  # present mode: a correction is blended in over this
    snap_distance_m: float = 4.0
    blend_time_s: float = 0.1
    stale_after_s: float = 1.0
    despawn_timeout_s: float = 3.0
    history_s: float = 2.0  # samples older than render time minus this are dropped
    implausible_s: float = 5.0  # a pose this far from session time is rejected


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


def hermite(
    p0: Coordinate, v0: Coordinate, p1: Coordinate, v1: Coordinate, s: float, h: float
) -> Coordinate:
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * h * v0
        + (-2 * s3 + 3 * s2) * p1
        + (s3 - s2) * h * v1
    )


GAIN = 0.05  # weight of a new sample in the running means of interval and latency


class StreamTiming:
    """Send interval and one-way latency of one stream, and the render delay it needs
    (running means and mean deviations, as TCP estimates its round trip)."""

    def __init__(self, s: InterpolationSettings) -> None:
        self.s = s
        self.interval_s = s.initial_interval_s
        self._interval_dev = 0.0
        self._latency = 0.0
        self._latency_dev = 0.0
        self._seeded = False
        self._last_t = -math.inf
        self.last_rx_t = -math.inf

    def observe(self, sent_t: float, rx_t: float) -> None:
        # Runs once per pose of every ego a node hears: the averages are updated in place,
        # not through a helper returning tuples (6 % of `WorldView.update` in a profile).
        latency = rx_t - sent_t
        last_t = self._last_t
        if sent_t > last_t > -math.inf:
            interval = sent_t - last_t
            if not self._seeded:
                self.interval_s, self._latency, self._seeded = interval, latency, True
            else:
                err = interval - self.interval_s
                self.interval_s += GAIN * err
                self._interval_dev += GAIN * (abs(err) - self._interval_dev)
        if self._seeded:
            err = latency - self._latency
            self._latency += GAIN * err
            self._latency_dev += GAIN * (abs(err) - self._latency_dev)
        else:
            self._latency = latency
        if sent_t > last_t:
            self._last_t = sent_t
        if rx_t > self.last_rx_t:
            self.last_rx_t = rx_t

    def target_delay(self) -> float:
        """Interval + latency + deviations: how far behind now samples are on both sides."""
        s = self.s
        if not s.adaptive:
            return s.initial_intervals * s.initial_interval_s
        if not self._seeded:
            return s.initial_intervals * self.interval_s
        spread = s.deviations * (self._latency_dev + self._interval_dev)
        target = self.interval_s + self._latency + spread + s.margin_s
        return min(s.max_delay_s, max(s.min_delay_s, target))


class DelaySlew:
    """A render delay that follows a target at a bounded rate, so motion never jumps."""

    def __init__(self, s: InterpolationSettings) -> None:
        self.s = s
        self.delay_s = s.initial_intervals * s.initial_interval_s
        self._t: float | None = None

    def follow(self, target: float, now: float) -> float:
        if self._t is not None:
            step = self.s.delay_slew * max(0.0, now - self._t)
            self.delay_s += max(-step, min(step, target - self.delay_s))
        self._t = now
        return self.delay_s


class RemoteActor:
    """The sample buffer and renderers for one remote actor. Not thread-safe: one owner."""

    def __init__(self, actor_id: str, settings: InterpolationSettings, kind: str = "") -> None:
        self.actor_id = actor_id
        self.kind = kind
        self.s = settings
        self._t: list[float] = []
        self._poses: list[Pose] = []
        self.timing = StreamTiming(settings)
        self._own_delay = DelaySlew(settings)  # for `view(now)` on a lone actor
        self.projector = Projector(settings)
        self._last_render_t: float | None = None
        self._corr = (0.0, 0.0, 0.0, 0.0)  # x, y, z, yaw error still to blend out
        self._corr_t = 0.0
        self.samples_received = 0
        self._snaps = 0
        # Rendering prunes the buffer (`past`, `present`); a view that never draws (an
        # observer's stats, the launcher's presence watch, a scripted node) would otherwise
        # keep every pose it hears: ~0.6 kB each, 12,800 a second at 256 egos. So `add` also
        # drops what no render can reach: older than the newest sample by more than the
        # longest render delay plus the history a render keeps. Halving the buffer once it
        # holds twice that costs one comparison per sample.
        self._keep_s = settings.max_delay_s + settings.history_s

    @property
    def snaps(self) -> int:
        return self._snaps + self.projector.snaps

    @property
    def last_rx_t(self) -> float:
        return self.timing.last_rx_t

    @property
    def delay_s(self) -> float:
        return self._own_delay.delay_s

    @property
    def newest(self) -> Pose | None:
        return self._poses[-1] if self._poses else None

    # ------------------------------------------------------------------ input

    def add(self, pose: Pose, rx_t: float) -> None:
        """Take a sample that arrived at session time `rx_t`."""
        ts, t = self._t, pose.t
        newest = not ts or t > ts[-1]
        if not newest and (t in ts or t < ts[0]):
            return  # duplicate or too old to matter
        self.samples_received += 1
        self.timing.observe(t, rx_t)
        # Only a view drawn in the past (`past`) has a render a new sample can correct; in
        # present mode there is none, and neither call is made (this runs once per pose).
        before = None if self._last_render_t is None else self._raw_at_last_render()
        if newest:  # nearly every sample: in order, so no search
            ts.append(t)
            self._poses.append(pose)
            self.projector.update(pose)
            if t - ts[0] > 2 * self._keep_s:
                self._prune(t - self._keep_s)
        else:
            i = bisect.bisect_right(ts, t)
            ts.insert(i, t)
            self._poses.insert(i, pose)
        if before is not None or pose.flags & POSE_FLAG_TELEPORT:
            self._correct(before, pose, rx_t)

    def _raw_at_last_render(self) -> _Vec4 | None:
        t = self._last_render_t
        if t is None or not self._t or t <= self._t[-1]:
            return None  # interpolation at t is not changed by a newer sample
        p = self._raw(t)[0]
        return p.x, p.y, p.z, p.yaw

    def _correct(self, before: _Vec4 | None, pose: Pose, now: float) -> None:
        if pose.flags & POSE_FLAG_TELEPORT:
            self._corr, self._snaps = (0.0, 0.0, 0.0, 0.0), self._snaps + 1
            return
        if before is None or self._last_render_t is None:
            return
        after = self._raw(self._last_render_t)[0]
        err = (before[0] - after.x, before[1] - after.y, before[2] - after.z,
               wrap_angle(before[3] - after.yaw))  # fmt: skip
        cx, cy, cz, cyaw = self._correction(now)
        total = (cx + err[0], cy + err[1], cz + err[2], cyaw + err[3])
        if math.hypot(total[0], total[1], total[2]) > self.s.snap_distance_m:
            self._corr, self._snaps = (0.0, 0.0, 0.0, 0.0), self._snaps + 1
        else:
            self._corr = total
        self._corr_t = now

    def _correction(self, now: float) -> _Vec4:
        if self._corr == (0.0, 0.0, 0.0, 0.0):
            return self._corr
        k = math.exp(-max(0.0, now - self._corr_t) / self.s.blend_time_s)
        return (self._corr[0] * k, self._corr[1] * k, self._corr[2] * k, self._corr[3] * k)

    # ------------------------------------------------------------------ output

    def target_delay(self) -> float:
        return self.timing.target_delay()

    def is_stale(self, now: float) -> bool:
        return now - self.timing.last_rx_t > self.s.stale_after_s

    def view(self, now: float) -> ActorView | None:
        """This actor alone, in the past at its own delay (the world view renders a view's
        actors at one common time instead: `past` or `present`)."""
        delay = self._own_delay.follow(self.timing.target_delay(), now)
        return self.past(now - delay, now)

    def past(self, render_t: float, now: float) -> ActorView | None:
        """Where it was at `render_t` (drawn at session time `now`); None before a sample."""
        if not self._t:
            return None
        self._prune(render_t)
        p, phase = self._raw(render_t)
        self._last_render_t = render_t
        cx, cy, cz, cyaw = self._correction(now)
        return ActorView(
            self.actor_id, p.x + cx, p.y + cy, p.z + cz, p.roll, p.pitch,
            wrap_angle(p.yaw + cyaw), p.vx, p.vy, p.vz, phase, self.is_stale(now), render_t,
        )  # fmt: skip

    def present(self, now: float) -> ActorView | None:
        """Where it is at `now`, projected from the newest sample; None before a sample."""
        if not self._t:
            return None
        self._prune(now - self.s.max_projection_s)
        p, holding = self.projector.at(now)
        phase = Phase.HOLDING if holding else Phase.EXTRAPOLATING
        return ActorView(
            self.actor_id, p.x, p.y, p.z, p.roll, p.pitch, p.yaw, p.vx, p.vy, p.vz,
            phase, self.is_stale(now), now,
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
        if dt > self.s.max_extrapolation_s:
            return project(p, self.s.max_extrapolation_s), Phase.HOLDING
        return project(p, dt), Phase.EXTRAPOLATING


def _interpolate(a: Pose, b: Pose, t: float) -> Pose:
    h = b.t - a.t
    s = (t - a.t) / h
    lin = lambda u, v: u + (v - u) * s  # noqa: E731 — tiny local helper on a hot path
    arc = lambda u, v: wrap_angle(u + wrap_angle(v - u) * s)  # noqa: E731
    return Pose(
        b.seq, t,
        hermite(a.x, a.vx, b.x, b.vx, s, h), hermite(a.y, a.vy, b.y, b.vy, s, h),
        hermite(a.z, a.vz, b.z, b.vz, s, h),
        arc(a.roll, b.roll), arc(a.pitch, b.pitch), arc(a.yaw, b.yaw),
        lin(a.vx, b.vx), lin(a.vy, b.vy), lin(a.vz, b.vz),
        lin(a.wx, b.wx), lin(a.wy, b.wy), lin(a.wz, b.wz),
    )  # fmt: skip
