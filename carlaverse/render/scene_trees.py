"""Trees: in parks, scattered as by nature, and along streets, each with its own round crown.

Placement is seeded by the map's name, so every node plants the same trees:

- in vegetation areas, a Poisson-disc sample (Bridson's algorithm: no two trunks closer than
  `PARK_SPACING_M`, no grid), at most `PARK_LIMIT` per area;
- beside sidewalks that run along a road, a street tree every `STREET_SPACING_M` (± a third)
  `STREET_SETBACK_M` beyond the sidewalk's outer edge.

A spot is kept only if the crown cannot reach over a road (its radius plus `ROAD_MARGIN_M`
from every vehicle lane's surface), the trunk stands off every footway, and the crown stays
clear of buildings and out of ponds. A tree is a six-sided trunk under one to three lumpy
spheres (a subdivided icosahedron whose vertices are pushed in or out), of random size and
one of a few greens.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.geometry import inside_polygon
from carlaverse.messages import MapArea, MapLane
from carlaverse.render import palette
from carlaverse.render.clearance import Clearance, lane_clearance
from carlaverse.render.meshes import (
    MeshBuilder,
    Point2,
    icosphere_size,
    line_length,
    offset_line,
    open_outline,
    sub_line,
)
from carlaverse.render.scene_roads import VEHICLE_KINDS, lanes_by_edge, neighbour

PARK_SPACING_M = 9.0  # [m] least distance between park trees
PARK_LIMIT = 300  # trees per park: a forest is suggested, not planted tree by tree
STREET_SPACING_M = 14.0  # [m] between street trees
STREET_SETBACK_M = 1.6  # [m] from the sidewalk's outer edge to the trunk
REACH_M = (1.8, 3.4)  # [m] how far a canopy reaches from its trunk
BUMP = 0.15  # a crown's vertices lie within ± this share of its radius
TRUNK_RADIUS_M = 0.16  # [m]
ROAD_MARGIN_M = 0.3  # [m] kept between a crown and a road lane
BUILDING_MARGIN_M = 0.5  # [m] kept between a crown and a wall
FOOTWAY_MARGIN_M = 0.4  # [m] kept between a trunk and a sidewalk's edge
# Crowns seen from near a street are subdivided icosahedra (80 triangles), those deeper in a
# park, seen from NEAR_STREET_M away or more, plain ones (20): a town's trees then cost about
# a third of the triangles, where a software rasteriser feels every vertex.
NEAR_STREET_M = 12.0  # [m]
CROWN_DETAIL = (0, 1)  # icosphere subdivisions: far from a street, near one
TILE_M = 100.0  # [m] side of the squares the trees are grouped in


@dataclass(frozen=True, slots=True)
class Tree:
    x: float  # [m]
    y: float  # [m]
    reach_m: float  # [m] how far its canopy reaches from the trunk, horizontally
    height_m: float  # [m] top of the canopy
    subdivisions: int = CROWN_DETAIL[1]  # of its crowns' icosahedra


def build_trees(trees: Sequence[Tree], seed: int) -> list[MeshBuilder]:
    """The trees as one untextured mesh per TILE_M square: the camera's frustum skips the
    squares out of view, and a town's trees are most of its triangles."""
    tiles: dict[tuple[int, int], MeshBuilder] = {}
    rng = random.Random(seed)
    for tree in trees:
        key = (math.floor(tree.x / TILE_M), math.floor(tree.y / TILE_M))
        mesh = tiles.setdefault(key, MeshBuilder(f"trees {key[0]},{key[1]}"))
        _tree(mesh, tree, rng)
    return [tiles[key] for key in sorted(tiles)]


def plant(areas: Sequence[MapArea], lanes: Sequence[MapLane], seed: int) -> list[Tree]:
    """Where trees stand on this map (the same map and seed give the same trees)."""
    rng = random.Random(seed)
    site = Site(areas, lanes)
    trees: list[Tree] = []
    for area in areas:
        if area.kind == "vegetation":
            outline = open_outline(area.polygon)
            spots = poisson_disc(outline, PARK_SPACING_M, rng, PARK_LIMIT)
            trees += site.keep(spots, rng)
    trees += site.keep(_street_spots(lanes, rng), rng)
    return _apart(trees)


def poisson_disc(outline: Sequence[Point2], spacing: float, rng: random.Random,
                 limit: int, tries: int = 20) -> list[Point2]:  # fmt: skip
    """Points inside the outline, none closer than `spacing` (Bridson 2007)."""
    if len(outline) < 3:
        return []
    xs, ys = [p[0] for p in outline], [p[1] for p in outline]
    x0, y0, x1, y1 = min(xs), min(ys), max(xs), max(ys)
    cell = spacing / math.sqrt(2)
    grid: dict[tuple[int, int], Point2] = {}
    first = (rng.uniform(x0, x1), rng.uniform(y0, y1))
    points, active = [first], [first]
    grid[(int((first[0] - x0) // cell), int((first[1] - y0) // cell))] = first
    while active and len(points) < 4 * limit:
        base = active[rng.randrange(len(active))]
        for _ in range(tries):
            a, r = rng.uniform(0, math.tau), rng.uniform(spacing, 2 * spacing)
            p = (base[0] + r * math.cos(a), base[1] + r * math.sin(a))
            if x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and _free(grid, p, x0, y0, cell, spacing):
                grid[(int((p[0] - x0) // cell), int((p[1] - y0) // cell))] = p
                points.append(p)
                active.append(p)
                break
        else:
            active.remove(base)
    inside = [p for p in points if inside_polygon(outline, *p)]
    return inside[:limit]


def _free(grid: dict[tuple[int, int], Point2], p: Point2, x0: float, y0: float, cell: float,
          spacing: float) -> bool:  # fmt: skip
    i, j = int((p[0] - x0) // cell), int((p[1] - y0) // cell)
    for di in range(-2, 3):
        for dj in range(-2, 3):
            q = grid.get((i + di, j + dj))
            if q is not None and math.dist(p, q) < spacing:
                return False
    return True


def _street_spots(lanes: Sequence[MapLane], rng: random.Random) -> list[Point2]:
    """Every STREET_SPACING_M (± a third) beside sidewalks that run along a road."""
    edges = lanes_by_edge(lanes)
    spots: list[Point2] = []
    for lane in lanes:
        left = neighbour(lane, edges, +1)
        if lane.kind != "sidewalk" or left is None or left.kind not in VEHICLE_KINDS:
            continue
        verge = offset_line(lane.centerline, -(lane.width / 2 + STREET_SETBACK_M))
        length = line_length(verge)
        s = rng.uniform(0.0, STREET_SPACING_M)
        while s < length:
            spots.append(sub_line(verge, s, s)[0])
            s += STREET_SPACING_M * rng.uniform(2 / 3, 4 / 3)
    return spots


class Site:
    """What a tree must keep clear of: roads, footways, buildings, ponds."""

    def __init__(self, areas: Sequence[MapArea], lanes: Sequence[MapLane]) -> None:
        self.roads = lane_clearance(lane for lane in lanes if lane.kind in VEHICLE_KINDS)
        self.footways = lane_clearance(lane for lane in lanes if lane.kind not in VEHICLE_KINDS)
        houses = [open_outline(a.polygon) for a in areas if a.kind == "building"]
        self.walls = Clearance(([*h, h[0]], 0.0) for h in houses if len(h) >= 3)
        self.houses = houses
        self.ponds = [open_outline(a.polygon) for a in areas if a.kind == "water"]

    def keep(self, spots: Sequence[Point2], rng: random.Random) -> list[Tree]:
        if not spots:
            return []
        xs, ys = np.array([p[0] for p in spots]), np.array([p[1] for p in spots])
        road, foot, wall = (c.distance(xs, ys) for c in (self.roads, self.footways, self.walls))
        trees = []
        for k, (x, y) in enumerate(spots):
            reach = rng.uniform(*REACH_M)
            room = min(road[k] - ROAD_MARGIN_M, wall[k] - BUILDING_MARGIN_M)
            if room < REACH_M[0] or foot[k] < FOOTWAY_MARGIN_M or self._inside(x, y):
                continue
            reach = min(reach, room)
            detail = CROWN_DETAIL[int(min(road[k], foot[k]) < NEAR_STREET_M)]
            trees.append(Tree(x, y, reach, reach * rng.uniform(2.4, 3.2), detail))
        return trees

    def _inside(self, x: float, y: float) -> bool:
        return any(inside_polygon(p, x, y) for p in (*self.houses, *self.ponds))


def _apart(trees: list[Tree]) -> list[Tree]:
    """Drop street trees that landed on a park tree (closer than half the park spacing)."""
    kept: list[Tree] = []
    for tree in trees:
        if all(math.hypot(tree.x - t.x, tree.y - t.y) >= PARK_SPACING_M / 2 for t in kept):
            kept.append(tree)
    return kept


def _tree(mesh: MeshBuilder, tree: Tree, rng: random.Random) -> None:
    """A trunk and crowns that stay within the tree's reach (bumps included)."""
    r = tree.reach_m / (1 + BUMP)  # the main crown's radius
    base = tree.height_m - 1.8 * r  # where the canopy starts
    trunk = [(tree.x + TRUNK_RADIUS_M * math.cos(a), tree.y + TRUNK_RADIUS_M * math.sin(a))
             for a in (k * math.pi / 3 for k in range(6))]  # fmt: skip
    for a, b in zip(trunk, trunk[1:] + trunk[:1], strict=True):  # no cap: it is in the crown
        mesh.wall(a, b, palette.GROUND_Z, base + 0.5 * r, palette.TREE_TRUNK)
    color = palette.TREE_CROWNS[rng.randrange(len(palette.TREE_CROWNS))]
    crowns = [(0.0, 0.0, base + 0.9 * r, r)]
    sides = rng.choice((0, 0, 0, 1, 2)) if tree.subdivisions else 0  # only near ones show them
    for _ in range(sides):  # some trees have side crowns
        side = r * rng.uniform(0.5, 0.7)
        # The side crown ends where the main one does.
        angle, off = rng.uniform(0, math.tau), r - side
        crowns.append(
            (off * math.cos(angle), off * math.sin(angle), base + rng.uniform(0.5, 1.1) * r, side)
        )
    count = icosphere_size(tree.subdivisions)
    for dx, dy, z, radius in crowns:
        bumps = [rng.uniform(1 - BUMP, 1 + BUMP) for _ in range(count)]
        squash = rng.uniform(0.85, 1.15)
        mesh.sphere((tree.x + dx, tree.y + dy, z), (radius, radius, radius * squash), color, bumps,
                    tree.subdivisions)  # fmt: skip
