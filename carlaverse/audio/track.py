"""A listener's path through a recording: its ego poses, interpolated at any render time."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from carlaverse import messages as m
from carlaverse.audio.listener import ListenerPose, ego_listener


class PoseTrack:
    """Poses sorted by session time; between two, position and yaw (shortest arc) linearly."""

    def __init__(self, poses: Sequence[m.Pose]) -> None:
        if not poses:
            raise ValueError("a pose track needs at least one pose")
        ordered = sorted(poses, key=lambda p: p.t)
        self.t = np.array([p.t for p in ordered])
        self.x = np.array([p.x for p in ordered])
        self.y = np.array([p.y for p in ordered])
        self.yaw = np.unwrap([p.yaw for p in ordered])
        self.vx = np.array([p.vx for p in ordered])
        self.vy = np.array([p.vy for p in ordered])

    def listener(self, t: float, head_offset_m: tuple[float, float, float]) -> ListenerPose:
        """The ears at session time `t` (held before the first and after the last pose)."""

        def at(values: np.ndarray) -> float:
            return float(np.interp(t, self.t, values))

        return ego_listener(at(self.x), at(self.y), at(self.yaw), (at(self.vx), at(self.vy)), t,
                            head_offset_m)  # fmt: skip
