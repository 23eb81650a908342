"""Walkable ground from the map the authority serves: sidewalks, crossings, walking areas.

With `lanes.snap` on, a step that would leave every walkable lane is pulled back to the
nearest point within the nearest one (a participant cannot drift onto the carriageway by
accident; crossings are walkable, so crossing the road means using one). Each lane is its
centre line with a width; a point is on it when within half the width (plus a margin) of
the line. A broadphase on the segments' boxes keeps a query cheap on a town-sized map.
"""

from __future__ import annotations

from typing import Annotated

import msgspec
import numpy as np

from carlaverse.config import StrictStruct
from carlaverse.messages import MapReply

WALKABLE_KINDS = ("sidewalk", "crossing", "walkingarea")


class LaneSettings(StrictStruct):
    snap: bool = False  # keep the walker on sidewalks, crossings and walking areas
    margin_m: Annotated[float, msgspec.Meta(ge=0)] = 0.25  # [m] tolerated beyond a lane's edge
    kinds: list[str] = msgspec.field(default_factory=lambda: list(WALKABLE_KINDS))


class Walkable:
    """Segments of every walkable lane as arrays: start (n, 2), direction (n, 2), half widths."""

    def __init__(self, starts: np.ndarray, ends: np.ndarray, half_widths: np.ndarray) -> None:
        self.a = np.asarray(starts, dtype=float).reshape(-1, 2)
        self.b = np.asarray(ends, dtype=float).reshape(-1, 2)
        self.half = np.asarray(half_widths, dtype=float).reshape(-1)
        self.d = self.b - self.a
        self.len2 = np.maximum((self.d**2).sum(axis=1), 1e-12)
        reach = self.half[:, None]
        self.lo = np.minimum(self.a, self.b) - reach
        self.hi = np.maximum(self.a, self.b) + reach

    @classmethod
    def from_map(cls, reply: MapReply, settings: LaneSettings) -> Walkable:
        starts, ends, halves = [], [], []
        for lane in reply.lanes:
            if lane.kind not in settings.kinds or len(lane.centerline) < 2:
                continue
            pts = lane.centerline
            starts += pts[:-1]
            ends += pts[1:]
            halves += [lane.width / 2 + settings.margin_m] * (len(pts) - 1)
        return cls(np.array(starts), np.array(ends), np.array(halves))

    def to_arrays(self) -> np.ndarray:
        """(n, 5): x0, y0, x1, y1, half width — what crosses to the loop process."""
        return np.column_stack([self.a, self.b, self.half])

    @classmethod
    def from_arrays(cls, rows: np.ndarray) -> Walkable:
        rows = np.asarray(rows, dtype=float).reshape(-1, 5)
        return cls(rows[:, 0:2], rows[:, 2:4], rows[:, 4])

    def __len__(self) -> int:
        return len(self.half)

    def _nearest(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
        """Closest points on every segment and the distance beyond each lane's band [m]."""
        p = np.array([x, y])
        t = np.clip(((p - self.a) * self.d).sum(axis=1) / self.len2, 0.0, 1.0)
        closest = self.a + t[:, None] * self.d
        beyond = np.hypot(*(p - closest).T) - self.half
        return closest, beyond

    def contains(self, x: float, y: float) -> bool:
        inside = np.all((self.lo <= (x, y)) & ((x, y) <= self.hi), axis=1)  # broadphase
        if not inside.any():
            return False
        return bool((self._nearest(x, y)[1][inside] <= 0).any())

    def constrain(self, x: float, y: float) -> tuple[float, float]:
        """(x, y) if walkable, else the nearest walkable point (on the nearest band's edge)."""
        if len(self) == 0 or self.contains(x, y):
            return x, y
        closest, beyond = self._nearest(x, y)
        i = int(np.argmin(beyond))
        cx, cy = closest[i]
        dist = float(np.hypot(x - cx, y - cy))
        k = (self.half[i] - 1e-6) / dist if dist > 0 else 0.0  # just inside the edge
        return float(cx + (x - cx) * k), float(cy + (y - cy) * k)
