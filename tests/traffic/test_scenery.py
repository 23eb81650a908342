"""Generated scenery: every shipped scenario gets buildings, vegetation and water, the same
ones for the same seed, and none of them on a lane."""

from __future__ import annotations

import itertools
from collections import Counter
from pathlib import Path

import pytest

from carlaverse.messages import MapArea, MapLane, MapReply
from carlaverse.traffic.mapdata import build_map_reply, read_net
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario
from carlaverse.traffic.scenery import CLEARANCE_M, scenery

SCENERY_KINDS = {"building", "vegetation", "water"}


def _reply(name: str, cache: Path, seed: int | None = None) -> MapReply:
    net = read_net(build_map(load_scenario(name), cache).net)
    return build_map_reply(net, name, seed=seed)


def _segments_cross(p, q, a, b) -> bool:
    def side(u, v, w) -> float:
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])

    return side(p, q, a) * side(p, q, b) < 0 and side(a, b, p) * side(a, b, q) < 0


def _inside(polygon, point) -> bool:
    x, y = point
    hit = False
    for (x0, y0), (x1, y1) in zip(polygon, [*polygon[1:], polygon[0]], strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit


def _touches(area: MapArea, lane: MapLane) -> bool:
    """The lane's centre line enters the area: a vertex inside, or crossing an edge."""
    poly, line = area.polygon, lane.centerline
    if any(_inside(poly, p) for p in line):
        return True
    edges = list(zip(poly, [*poly[1:], poly[0]], strict=True))
    return any(_segments_cross(p, q, a, b) for p, q in itertools.pairwise(line)
               for a, b in edges)  # fmt: skip


@pytest.mark.parametrize("name", ["town", "crossing", "ring"])
def test_shipped_scenarios_get_scenery_off_every_lane(name: str, net_cache: Path) -> None:
    reply = _reply(name, net_cache)
    areas = [a for a in reply.areas if a.kind in SCENERY_KINDS]
    counts = Counter(a.kind for a in areas)
    assert counts["building"] >= 4 and counts["vegetation"] >= 1, counts
    for area in areas:
        for lane in reply.lanes:
            assert not _touches(area, lane), f"{area.id} ({area.kind}) lies on {lane.id}"


def test_town_has_all_three_kinds_and_the_same_seed_gives_the_same_areas(net_cache: Path) -> None:
    first = _reply("town", net_cache)
    assert {a.kind for a in first.areas} >= SCENERY_KINDS
    assert _reply("town", net_cache).areas == first.areas
    other = _reply("town", net_cache, seed=12345)
    assert other.areas != first.areas
    assert _reply("town", net_cache, seed=12345).areas == other.areas


def test_areas_keep_clear_of_a_lane_by_the_clearance() -> None:
    """One straight 3.5 m lane through a 200 m square: nothing within width/2 + clearance."""
    lane = MapLane("east_0", "road", 3.5, [(-100.0, 0.0), (100.0, 0.0)])
    areas = scenery((-100.0, -100.0, 100.0, 100.0), [lane], [], seed=1)
    assert areas
    for area in areas:
        ys = [y for _, y in area.polygon]
        nearest = min(abs(y) for y in ys) if min(ys) * max(ys) > 0 else 0.0
        assert nearest >= 3.5 / 2 + CLEARANCE_M, (area.id, ys)


def _taken_everywhere(grid, lanes, junctions):
    """The reference: every segment and polygon over the whole grid (slow, plainly right)."""
    import numpy as np

    from carlaverse.traffic.scenery import CELL_M, _inside

    cx, cy = grid.centres()
    taken = np.zeros(cx.shape, dtype=bool)
    lines = [(lane.centerline, lane.width / 2) for lane in lanes]
    lines += [([*a.polygon, a.polygon[0]], 0.0) for a in junctions]
    for line, half_width in lines:
        reach = half_width + CLEARANCE_M + CELL_M * np.sqrt(0.5)
        for (ax, ay), (bx, by) in itertools.pairwise(line):
            dx, dy = bx - ax, by - ay
            s = np.clip(((cx - ax) * dx + (cy - ay) * dy) / (dx * dx + dy * dy or 1e-12), 0, 1)
            taken |= (cx - ax - s * dx) ** 2 + (cy - ay - s * dy) ** 2 <= reach * reach
    for area in junctions:
        taken |= _inside(cx, cy, area.polygon)
    return taken


def test_cells_are_taken_as_if_every_segment_looked_at_the_whole_grid() -> None:
    import numpy as np

    from carlaverse.traffic.scenery import Grid, _taken

    rng = np.random.default_rng(7)
    grid = Grid(-203.0, -151.0, 110, 90)  # 440 × 360 m, cell centres off any round number
    lanes = [
        MapLane(
            f"l{i}",
            "road",
            float(rng.uniform(1.5, 4.0)),
            [tuple(p) for p in rng.uniform(-260, 260, (int(rng.integers(2, 6)), 2))],
        )
        for i in range(40)
    ]  # fmt: skip  (some reach past the grid's edges)
    junctions = [MapArea(f"j{i}", "junction",
                         [tuple(c + p) for p in rng.uniform(-12, 12, (5, 2))])
                 for i, c in enumerate(rng.uniform(-220, 220, (12, 2)))]  # fmt: skip
    expected = _taken_everywhere(grid, lanes, junctions)
    assert 0.05 < expected.mean() < 0.95  # a mix of taken and free cells to compare
    assert np.array_equal(_taken(grid, lanes, junctions), expected)
