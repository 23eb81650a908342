"""The chase camera of `carlaverse render --camera ID --chase`: behind and above an actor.

The eye sits `BACK_M` behind the actor's reference point (the centre of its footprint) along
the heading it trails and `UP_M` above the road under the actor, and looks at the point
`AIM_AHEAD_M` ahead of the actor and `AIM_UP_M` up: the actor shows in the lower middle of
the picture with the road ahead above it (with the numbers below, the actor's centre is
~8° below the middle of the view). The trailed heading follows the actor's yaw through a
first-order lag of `YAW_LAG_S`, so a clip swings round a turn instead of snapping; a still,
or a jump back in time, starts on the actor's own yaw.

The rig hangs its head (and cameras) off the anchor at the rig's head position; `ChaseCamera`
places the anchor so that the head, not the anchor, is where the eye should be.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from carlaverse.render.cameras import Eye
from carlaverse.render.frame import ActorDraw
from carlaverse.render.rig import HeadPosition
from carlaverse.support.angles import wrap_angle

BACK_M = 6.0  # [m] eye behind the actor, along the trailed heading
UP_M = 2.5  # [m] eye above the road under the actor
AIM_AHEAD_M = 4.0  # [m] the point looked at: ahead of the actor ...
AIM_UP_M = 1.0  # [m] ... and this high above the road
YAW_LAG_S = 0.5  # [s] time constant of the heading the camera trails
RESTART_GAP_S = 1.0  # [s] a frame further from the last than this starts afresh


class ChasePose(NamedTuple):
    """Where the eye is and where it looks [m, rad]; pitch nose down positive."""

    x: float
    y: float
    z: float
    yaw: float
    pitch: float


def chase_pose(x: float, y: float, z: float, heading: float) -> ChasePose:
    """The eye behind and above the actor at (x, y, z) [m], trailing `heading` [rad]."""
    c, s = math.cos(heading), math.sin(heading)
    pitch = math.atan2(UP_M - AIM_UP_M, BACK_M + AIM_AHEAD_M)  # down onto the aim point
    return ChasePose(x - BACK_M * c, y - BACK_M * s, z + UP_M, heading, pitch)


def anchor_for(pose: ChasePose, head: HeadPosition) -> Eye:
    """The rig anchor that puts a head at `head` (actor frame) on the eye of `pose`.

    The anchor's axes: forward f (yaw, pitched down by `pitch`), right r, up u = r × f; the
    head sits at head.x·f + head.y·(−r) + head.z·u from it (x forward, y left, z up).
    """
    cy, sy = math.cos(pose.yaw), math.sin(pose.yaw)
    cp, sp = math.cos(pose.pitch), math.sin(pose.pitch)
    forward = (cy * cp, sy * cp, -sp)
    right = (sy, -cy, 0.0)
    up = (cy * sp, sy * sp, cp)  # r × f
    ox, oy, oz = (
        head.x * f - head.y * r + head.z * u for f, r, u in zip(forward, right, up, strict=True)
    )
    return Eye(pose.x - ox, pose.y - oy, pose.z - oz, pose.yaw, pose.pitch)


class ChaseCamera:
    """The anchor of a chase camera frame by frame, its heading lagging the actor's yaw."""

    def __init__(self, head: HeadPosition, lag_s: float = YAW_LAG_S) -> None:
        self.head = head
        self.lag_s = lag_s
        self.heading: float | None = None  # [rad] the trailed heading
        self.t: float | None = None  # [s] session time of the last frame

    def eye(self, actor: ActorDraw, t: float) -> Eye:
        """The anchor for the frame at session time `t` [s] showing `actor`."""
        dt = t - self.t if self.t is not None else None
        if self.heading is None or dt is None or not 0.0 <= dt <= RESTART_GAP_S:
            self.heading = actor.yaw
        else:
            follow = 1.0 - math.exp(-dt / self.lag_s)
            self.heading = wrap_angle(self.heading + follow * wrap_angle(actor.yaw - self.heading))
        self.t = t
        return anchor_for(chase_pose(actor.x, actor.y, actor.z, self.heading), self.head)
