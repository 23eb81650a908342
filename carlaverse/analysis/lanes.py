"""Which lane a road user was on: the nearest centreline of the map the recording kept.

An NPC's id is whatever the traffic engine named it (`veh12`, `flow_3.7`) and says nothing to
a reader; the lanes it drove along do. A point is on the lane whose centreline is nearest, if
that is within half the lane's width plus `MARGIN_M`. Centrelines are sampled every `STEP_M`
and the samples bucketed in a grid of `CELL_M` cells, so a look-up reads a few cells, not
every lane of a town.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict

import numpy as np

from carlaverse import messages as m

STEP_M = 1.0  # [m] between centreline samples: a look-up is off by at most half of it
CELL_M = 10.0  # [m] grid cell; no lane in a town is wider than this
MARGIN_M = 0.5 + STEP_M / 2  # [m] beyond the lane's edge still on it (a wide car, sampling)


class LaneIndex:
    """Nearest-lane look-ups over one map (an empty index without a map)."""

    def __init__(self, road_map: m.MapReply | None) -> None:
        lanes = [lane for lane in (road_map.lanes if road_map else []) if len(lane.centerline) >= 2]
        self.ids = [lane.id for lane in lanes]
        samples = [_sample(lane.centerline) for lane in lanes]
        self.points = np.concatenate(samples) if samples else np.zeros((0, 2))
        self.lane_of = np.concatenate(
            [np.full(len(s), k) for k, s in enumerate(samples)] or [np.zeros(0, int)]
        )
        self.reach = np.array([lane.width / 2 + MARGIN_M for lane in lanes])  # [m] per lane
        cells: defaultdict[tuple[int, int], list[int]] = defaultdict(list)
        for k, (x, y) in enumerate(self.points):
            cells[(math.floor(x / CELL_M), math.floor(y / CELL_M))].append(k)
        self.cells = {cell: np.array(ks) for cell, ks in cells.items()}

    def lane_at(self, x: float, y: float) -> str:
        """The id of the lane at (x, y) [m], '' when on none (or the position is unknown)."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return ""
        cx, cy = math.floor(x / CELL_M), math.floor(y / CELL_M)
        near = [self.cells[c] for c in _around(cx, cy) if c in self.cells]
        if not near:
            return ""
        ks = np.concatenate(near)
        d = np.hypot(self.points[ks, 0] - x, self.points[ks, 1] - y)
        best = int(np.argmin(d))
        lane = int(self.lane_of[ks[best]])
        return self.ids[lane] if d[best] <= self.reach[lane] else ""

    def route(self, xs: np.ndarray, ys: np.ndarray) -> list[str]:
        """The lanes a path went along, in order, each once per visit ('' stretches left out)."""
        out: list[str] = []
        for x, y in zip(xs, ys, strict=True):
            lane = self.lane_at(float(x), float(y))
            if lane and (not out or out[-1] != lane):
                out.append(lane)
        return out


def _sample(centerline: list[tuple[float, float]]) -> np.ndarray:
    """Points along a polyline at most STEP_M apart, both ends included."""
    line = np.asarray(centerline, dtype=np.float64)
    pieces = [line[:1]]
    for a, b in itertools.pairwise(line):
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / STEP_M))
        pieces.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.concatenate(pieces)


def _around(cx: int, cy: int) -> list[tuple[int, int]]:
    return [(cx + i, cy + j) for i in (-1, 0, 1) for j in (-1, 0, 1)]
