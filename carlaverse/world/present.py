"""Present mode: draw a remote actor where it is now, not where it was (docs/architecture.md §7).

The newest sample is projected to now by the one motion model every user of a pose shares
(`carlaverse.dead_reckoning`: its velocity turning at its yaw rate, its acceleration). A new
sample usually disagrees a little with the projection that was on screen; jumping to the new
projection would show as a twitch every sample, so the change is blended in *projectively*
(Murphy's projective velocity blending, the scheme Fiedler's networked-physics articles and
DIS smoothing describe): from the moment the sample is first drawn (T0), with the shown
position P0 and velocity V0 then,

    λ = min(1, (t − T0) / present_blend_s)
    Vb = V0 + (V' − V0) λ                      V' = the new projection's velocity at T0
    Pb = P0 + Vb (t − T0) + ½ A' (t − T0)²     the old motion, its velocity turning into the new
                                               (A' = the new projection's acceleration at T0)
    shown = Pb + (P'(t) − Pb) λ                P'(t) = the new sample projected to t

so position and velocity both stay continuous and the shown track converges onto the new
projection within the blend time. A disagreement over `snap_distance_m` (or a teleport flag)
snaps. Beyond `max_projection_s` without a new sample the actor is held where it got to.
"""

from __future__ import annotations

import math
from typing import Protocol

from carlaverse.dead_reckoning import project
from carlaverse.messages import POSE_FLAG_TELEPORT, Pose
from carlaverse.support.angles import wrap_angle

_Vec3 = tuple[float, float, float]


class ProjectionSettings(Protocol):
    """The three of a node's `InterpolationSettings` present mode reads (structural, so this
    module needs nothing of `remote_actor`, which builds a `Projector` per actor)."""

    @property
    def max_projection_s(self) -> float: ...  # [s] projected at most this far past a sample

    @property
    def present_blend_s(self) -> float: ...  # [s] a correction is blended in over this

    @property
    def snap_distance_m(self) -> float: ...  # [m] a larger disagreement snaps


class Projector:
    """The present-mode renderer of one actor. Not thread-safe: one owner."""

    def __init__(self, settings: ProjectionSettings) -> None:
        self.s = settings
        self._sample: Pose | None = None
        self._pending = False  # a sample not yet drawn: the next frame starts its blend
        self._t0 = 0.0
        self._at_t0: Pose | None = None  # the new sample projected to T0 (once per blend)
        self._p0: _Vec3 = (0.0, 0.0, 0.0)
        self._v0: _Vec3 = (0.0, 0.0, 0.0)
        self._yaw0 = 0.0
        self._shown: tuple[float, Pose] | None = None  # what was drawn last, and when
        self.snaps = 0

    def update(self, newest: Pose) -> None:
        """A sample newer than any before arrived."""
        self._sample = newest
        self._pending = True

    def at(self, now: float) -> tuple[Pose, bool]:
        """The pose to draw at `now`, and whether it is held (no sample for too long)."""
        s = self._sample
        assert s is not None, "at() before the first sample"
        dt = now - s.t
        holding = dt > self.s.max_projection_s
        target = project(s, min(dt, self.s.max_projection_s))
        if self._pending:
            self._start_blend(now, s)
        tau = max(0.0, now - self._t0)
        lam = min(1.0, tau / self.s.present_blend_s) if self.s.present_blend_s > 0 else 1.0
        pose = target if lam >= 1.0 else self._blend(target, s, tau, lam)
        if holding:
            pose = _still(pose)
        self._shown = (now, pose)
        return pose, holding

    def _start_blend(self, now: float, s: Pose) -> None:
        self._pending = False
        at_t0 = project(s, min(now - s.t, self.s.max_projection_s))
        shown = self._shown_at(now)
        if (
            shown is None
            or s.flags & POSE_FLAG_TELEPORT
            or math.dist(shown[0], (at_t0.x, at_t0.y, at_t0.z)) > self.s.snap_distance_m
        ):
            if shown is not None:
                self.snaps += 1
            shown = ((at_t0.x, at_t0.y, at_t0.z), (at_t0.vx, at_t0.vy, at_t0.vz), at_t0.yaw)
        self._t0, self._at_t0 = now, at_t0
        self._p0, self._v0, self._yaw0 = shown

    def _shown_at(self, now: float) -> tuple[_Vec3, _Vec3, float] | None:
        """What was on screen, carried on to `now` by the model (frames are ms apart)."""
        if self._shown is None:
            return None
        t, shown = self._shown
        p = project(shown, now - t)
        return (p.x, p.y, p.z), (p.vx, p.vy, p.vz), p.yaw

    def _blend(self, target: Pose, s: Pose, tau: float, lam: float) -> Pose:
        at_t0 = self._at_t0
        assert at_t0 is not None, "a blend before its start"
        v1 = (at_t0.vx, at_t0.vy, at_t0.vz)
        acc = (at_t0.ax, at_t0.ay, at_t0.az)  # A'
        p_t = (target.x, target.y, target.z)
        shown, vel = [], []
        for i in range(3):
            vb = self._v0[i] + (v1[i] - self._v0[i]) * lam
            pb = self._p0[i] + vb * tau + 0.5 * acc[i] * tau * tau
            shown.append(pb + (p_t[i] - pb) * lam)
            vel.append(vb + acc[i] * tau)
        old_yaw = self._yaw0 + s.wz * tau
        yaw = wrap_angle(old_yaw + wrap_angle(target.yaw - old_yaw) * lam)
        tv = (target.vx, target.vy, target.vz)
        v = [vel[i] + (tv[i] - vel[i]) * lam for i in range(3)]
        return Pose(
            s.seq, target.t, shown[0], shown[1], shown[2], target.roll, target.pitch, yaw,
            v[0], v[1], v[2], s.wx, s.wy, s.wz, acc[0], acc[1], acc[2],
        )  # fmt: skip


def _still(p: Pose) -> Pose:
    return Pose(p.seq, p.t, p.x, p.y, p.z, p.roll, p.pitch, p.yaw)
