"""How far points are from the lanes' surfaces: to keep trees off roads and find the walls of
a building that face a street.

Lane segments are bucketed in square cells, so a query looks only at the segments near it:
a town's thousands of segments against thousands of candidate points stay a few milliseconds.
Beyond `reach_m` the distance is reported as `reach_m` (nothing is that close).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

import numpy as np

from carlaverse.messages import MapLane

CELL_M = 20.0  # [m] bucket side
Point2 = tuple[float, float]


class Clearance:
    """Distances from points to the nearest of some strips (polylines with a width) [m]."""

    def __init__(
        self, strips: Iterable[tuple[Sequence[Point2], float]], reach_m: float = 30.0
    ) -> None:
        self.reach_m = reach_m
        rows: dict[tuple[int, int], list[tuple[float, float, float, float, float]]] = {}
        for line, width in strips:
            half = width / 2
            for (ax, ay), (bx, by) in itertools.pairwise(line):
                for cell in _cells(ax, ay, bx, by, half + reach_m):
                    rows.setdefault(cell, []).append((ax, ay, bx, by, half))
        self._cells = {cell: np.array(r) for cell, r in rows.items()}

    def distance(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Distance from each point to the nearest strip's edge (negative: on a strip)."""
        xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
        out = np.full(xs.shape, self.reach_m)
        keys = np.stack([np.floor(xs / CELL_M), np.floor(ys / CELL_M)], axis=-1).astype(int)
        for key in {tuple(k) for k in keys.reshape(-1, 2).tolist()}:
            seg = self._cells.get((key[0], key[1]))
            if seg is None:
                continue
            pick = (keys[..., 0] == key[0]) & (keys[..., 1] == key[1])
            out[pick] = np.minimum(out[pick], _to_segments(xs[pick], ys[pick], seg))
        return out

    def at(self, x: float, y: float) -> float:
        return float(self.distance(np.array([x]), np.array([y]))[0])


def lane_clearance(lanes: Iterable[MapLane], reach_m: float = 30.0) -> Clearance:
    """Distances to the surfaces of these lanes."""
    return Clearance(((lane.centerline, lane.width) for lane in lanes), reach_m)


def _cells(ax: float, ay: float, bx: float, by: float, grow: float) -> list[tuple[int, int]]:
    i0, i1 = math.floor((min(ax, bx) - grow) / CELL_M), math.floor((max(ax, bx) + grow) / CELL_M)
    j0, j1 = math.floor((min(ay, by) - grow) / CELL_M), math.floor((max(ay, by) + grow) / CELL_M)
    return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]


def _to_segments(x: np.ndarray, y: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Per point, the smallest distance to a segment's centre line less its half width."""
    ax, ay, bx, by, half = (seg[:, k][None, :] for k in range(5))
    dx, dy = bx - ax, by - ay
    length2 = np.maximum(dx * dx + dy * dy, 1e-12)
    px, py = x[:, None], y[:, None]
    s = np.clip(((px - ax) * dx + (py - ay) * dy) / length2, 0.0, 1.0)
    gap = np.hypot(px - ax - s * dx, py - ay - s * dy) - half
    return gap.min(axis=1)
