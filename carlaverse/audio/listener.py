"""Where the ears are and which way the head faces: the ego's head, or an XR head pose.

World frame: x east, y north, z up (the road network's). Head frame: x forward, y left, z up
(as the HRTF sets). An XR headset reports its pose in stage space (x right, y up, z back);
the stage is fixed to the vehicle with its origin at the configured head position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

# Stage axes (x right, y up, z back) expressed in the head/vehicle frame (x fwd, y left, z up).
STAGE_TO_VEHICLE = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class ListenerPose:
    """The listener at render time `t` [s]; `rotation` maps head-frame vectors to world."""

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))  # [m]
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # [m/s]
    t: float = 0.0  # [s]

    def at(self, t: float) -> np.ndarray:
        """Position [m] dead-reckoned to time `t`."""
        return self.position + self.velocity * (t - self.t)


def yaw_rotation(yaw_rad: float) -> np.ndarray:
    """Head frame → world for a level head facing `yaw_rad` (counter-clockwise from east)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def quaternion_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def ego_listener(x: float, y: float, yaw: float, velocity: tuple[float, float], t: float,
                 head_offset_m: tuple[float, float, float]) -> ListenerPose:  # fmt: skip
    """The ego's head: the vehicle pose plus the head's offset in the vehicle frame."""
    rotation = yaw_rotation(yaw)
    position = np.array([x, y, 0.0]) + rotation @ np.asarray(head_offset_m)
    return ListenerPose(position, rotation, np.array([*velocity, 0.0]), t)


def with_head_pose(ego: ListenerPose, position_m: tuple[float, float, float],
                   orientation: tuple[float, float, float, float]) -> ListenerPose:  # fmt: skip
    """The ego's listener moved and turned by an XR head pose (stage space, relative to the
    configured head position)."""
    head = STAGE_TO_VEHICLE @ quaternion_matrix(*orientation) @ STAGE_TO_VEHICLE.T
    offset = ego.rotation @ (STAGE_TO_VEHICLE @ np.asarray(position_m))
    return ListenerPose(ego.position + offset, ego.rotation @ head, ego.velocity, ego.t)
