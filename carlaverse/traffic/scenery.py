"""Scenery for maps that bring none: buildings, vegetation and water between the streets.

Generated towns (and hand-written networks without a .poly.xml) have roads only. Their free
land is found on a grid: a cell is taken when any lane (road, sidewalk, bike lane, crossing)
or junction comes within `CLEARANCE_M` of it. The free cells are cut into rectangles (runs
along x, merged across rows with the same span), and each rectangle becomes, dealt from a
seeded deck, a block of buildings around a courtyard, a park (vegetation), or a pond in a park.
The same map and seed give the same areas, so every node and every recording agree; and no
area can reach a lane, since only free cells are used.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.messages import MapArea, MapLane

CELL_M = 4.0  # [m] grid cell side
CLEARANCE_M = 2.0  # [m] kept free between a lane's edge (or a junction) and any area
MARGIN_M = 40.0  # [m] scenery reaches this far beyond the network's bounding box
MIN_SIDE_M = 12.0  # [m] rectangles narrower than this stay bare ground
BUILDING_DEPTH_M = (10.0, 16.0)  # [m] from the street into the block
LOT_WIDTH_M = (12.0, 26.0)  # [m] along the street
# What every ten rectangles become, dealt in a seeded order: a map of ten blocks or more has
# all three kinds, and the mix holds on any map.
DECK = ("building",) * 6 + ("vegetation",) * 3 + ("water",)

Rect = tuple[float, float, float, float]  # xmin, ymin, xmax, ymax [m]


@dataclass(frozen=True, slots=True)
class Grid:
    x0: float  # [m] west edge
    y0: float  # [m] south edge
    nx: int
    ny: int

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        xs = self.x0 + (np.arange(self.nx) + 0.5) * CELL_M
        ys = self.y0 + (np.arange(self.ny) + 0.5) * CELL_M
        return np.meshgrid(xs, ys)  # (ny, nx) each


def scenery(
    bounds: Rect, lanes: Sequence[MapLane], junctions: Sequence[MapArea], seed: int
) -> list[MapArea]:
    """Buildings, vegetation and water on the land no lane or junction uses."""
    xmin, ymin, xmax, ymax = bounds
    grid = Grid(
        xmin - MARGIN_M, ymin - MARGIN_M,
        int((xmax - xmin + 2 * MARGIN_M) // CELL_M), int((ymax - ymin + 2 * MARGIN_M) // CELL_M),
    )  # fmt: skip
    free = ~_taken(grid, lanes, junctions)
    rng = random.Random(seed)
    areas: list[MapArea] = []
    rects = free_rectangles(grid, free)
    largest = max(rects, key=_area, default=None)
    deck: list[str] = []
    for k, rect in enumerate(rects):
        if rect == largest:  # every map gets a park with a pond, however few its blocks
            areas += _fill(f"scenery{k}", rect, "water", rng)
            continue
        if not deck:
            deck = list(DECK)
            rng.shuffle(deck)
        areas += _fill(f"scenery{k}", rect, deck.pop(), rng)
    return areas


def _taken(grid: Grid, lanes: Sequence[MapLane], junctions: Sequence[MapArea]) -> np.ndarray:
    """Cells within clearance of a lane's surface or a junction's outline (ny, nx)."""
    cx, cy = grid.centres()
    taken = np.zeros(cx.shape, dtype=bool)
    half_cell = CELL_M * np.sqrt(0.5)  # a cell is taken if any part of it is too close
    for lane in lanes:
        reach = lane.width / 2 + CLEARANCE_M + half_cell
        _mark_near_polyline(grid, cx, cy, taken, lane.centerline, reach)
    for area in junctions:
        outline = [*area.polygon, area.polygon[0]]
        _mark_near_polyline(grid, cx, cy, taken, outline, CLEARANCE_M + half_cell)
        window = _window(grid, *_grown_box(area.polygon, 0.0))
        if window is not None:
            taken[window] |= _inside(cx[window], cy[window], area.polygon)
    return taken


def _mark_near_polyline(grid: Grid, cx: np.ndarray, cy: np.ndarray, taken: np.ndarray,
                        line: Sequence[tuple[float, float]], reach: float) -> None:  # fmt: skip
    """Mark the cells within `reach` of the polyline. Each segment looks only at the cells of
    its own box grown by `reach`: a town's thousands of segments each touch a few cells, and
    computing every segment over the whole grid made large maps take minutes."""
    for (ax, ay), (bx, by) in itertools.pairwise(line):
        window = _window(grid, *_grown_box(((ax, ay), (bx, by)), reach))
        if window is None:
            continue
        x, y = cx[window], cy[window]
        dx, dy = bx - ax, by - ay
        length2 = dx * dx + dy * dy or 1e-12
        s = np.clip(((x - ax) * dx + (y - ay) * dy) / length2, 0.0, 1.0)
        taken[window] |= (x - ax - s * dx) ** 2 + (y - ay - s * dy) ** 2 <= reach * reach


def _grown_box(points: Sequence[tuple[float, float]], reach: float) -> Rect:
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return min(xs) - reach, min(ys) - reach, max(xs) + reach, max(ys) + reach


def _window(grid: Grid, xmin: float, ymin: float, xmax: float,
            ymax: float) -> tuple[slice, slice] | None:  # fmt: skip
    """The (rows, columns) of the cells whose centres may lie in the box; None if none do."""
    ix0 = max(0, int(np.floor((xmin - grid.x0) / CELL_M - 0.5)))
    ix1 = min(grid.nx, int(np.ceil((xmax - grid.x0) / CELL_M - 0.5)) + 1)
    iy0 = max(0, int(np.floor((ymin - grid.y0) / CELL_M - 0.5)))
    iy1 = min(grid.ny, int(np.ceil((ymax - grid.y0) / CELL_M - 0.5)) + 1)
    if ix0 >= ix1 or iy0 >= iy1:
        return None
    return slice(iy0, iy1), slice(ix0, ix1)


def _inside(cx: np.ndarray, cy: np.ndarray, polygon: Sequence[tuple[float, float]]) -> np.ndarray:
    """Even-odd rule, vectorised over the cell centres."""
    hit = np.zeros(cx.shape, dtype=bool)
    for (x0, y0), (x1, y1) in zip(polygon, [*polygon[1:], polygon[0]], strict=True):
        if y0 == y1:
            continue
        crosses = (y0 > cy) != (y1 > cy)
        hit ^= crosses & (cx < x0 + (cy - y0) * (x1 - x0) / (y1 - y0))
    return hit


def free_rectangles(grid: Grid, free: np.ndarray) -> list[Rect]:
    """Free cells as rectangles: runs along x, merged with the rows above of the same span."""
    open_runs: dict[tuple[int, int], int] = {}  # (i0, i1) -> first row
    rects: list[Rect] = []
    for j in range(grid.ny + 1):
        runs = set(_runs(free[j])) if j < grid.ny else set()
        for span in [s for s in open_runs if s not in runs]:
            rects.append(_rect(grid, span, open_runs.pop(span), j))
        for span in runs:
            open_runs.setdefault(span, j)
    rects.sort()  # a stable order: the seeded draws must not depend on dict order
    return [r for r in rects if min(r[2] - r[0], r[3] - r[1]) >= MIN_SIDE_M]


def _area(rect: Rect) -> float:
    return (rect[2] - rect[0]) * (rect[3] - rect[1])


def _runs(row: np.ndarray) -> list[tuple[int, int]]:
    padded = np.concatenate(([False], row, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _rect(grid: Grid, span: tuple[int, int], j0: int, j1: int) -> Rect:
    i0, i1 = span
    return (grid.x0 + i0 * CELL_M, grid.y0 + j0 * CELL_M,
            grid.x0 + i1 * CELL_M, grid.y0 + j1 * CELL_M)  # fmt: skip


def _fill(prefix: str, rect: Rect, kind: str, rng: random.Random) -> list[MapArea]:
    if kind == "building":
        return [MapArea(f"{prefix}-b{k}", "building", _box(r)) for k, r in
                enumerate(building_lots(rect, rng))]  # fmt: skip
    park = MapArea(f"{prefix}-park", "vegetation", _box(rect))
    if kind == "water":
        return [park, MapArea(f"{prefix}-pond", "water", _pond(rect))]
    return [park]


def building_lots(rect: Rect, rng: random.Random) -> list[Rect]:
    """Buildings along all four sides of a block, a courtyard left in the middle."""
    xmin, ymin, xmax, ymax = rect
    depth = min(rng.uniform(*BUILDING_DEPTH_M), (xmax - xmin) / 2, (ymax - ymin) / 2)
    lots = []
    for a, b in _split(xmin, xmax, rng):  # south and north rows span the whole width
        lots += [(a, ymin, b, ymin + depth), (a, ymax - depth, b, ymax)]
    if ymax - ymin > 2 * depth + LOT_WIDTH_M[0]:
        for a, b in _split(ymin + depth, ymax - depth, rng):  # west and east rows between
            lots += [(xmin, a, xmin + depth, b), (xmax - depth, a, xmax, b)]
    return lots


def _split(lo: float, hi: float, rng: random.Random) -> list[tuple[float, float]]:
    """[lo, hi] cut into lots of LOT_WIDTH_M (the last one takes what is left)."""
    cuts = [lo]
    while hi - cuts[-1] > 2 * LOT_WIDTH_M[0]:
        cuts.append(cuts[-1] + rng.uniform(*LOT_WIDTH_M))
    if cuts[-1] >= hi - LOT_WIDTH_M[0] / 2 and len(cuts) > 1:
        cuts.pop()
    return list(zip(cuts, [*cuts[1:], hi], strict=True))


def _box(rect: Rect) -> list[tuple[float, float]]:
    xmin, ymin, xmax, ymax = rect
    return [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]


def _pond(rect: Rect, corners: int = 12) -> list[tuple[float, float]]:
    """An ellipse inside the park, a fifth of its side away from every edge."""
    xmin, ymin, xmax, ymax = rect
    cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
    rx, ry = 0.3 * (xmax - xmin), 0.3 * (ymax - ymin)
    angles = np.linspace(0.0, 2 * np.pi, corners, endpoint=False)
    return [(float(cx + rx * np.cos(a)), float(cy + ry * np.sin(a))) for a in angles]
