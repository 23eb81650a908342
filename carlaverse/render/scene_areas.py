"""Areas from the map: the ground, junctions, buildings, vegetation with trees, water.

Heights are not in the map, so buildings get one from their id (a stable hash: the same map
always looks the same, on every node). Trees are scattered on a grid inside vegetation, also
deterministically.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Sequence

from carlaverse.geometry import inside_polygon
from carlaverse.messages import MapArea
from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, Point2, open_outline

BUILDING_HEIGHT_M = (6.0, 24.0)  # [m] range of generated building heights
TREE_SPACING_M = 9.0  # [m] grid of trees inside vegetation
TREE_LIMIT = 400  # per area: a forest is suggested, not planted tree by tree
GROUND_MARGIN_M = 200.0  # [m] the ground plane reaches this far beyond the map
GROUND_CELLS = 80  # per side: fog is per vertex, so the ground needs vertices near the eye


def build_ground(bounds: tuple[float, float, float, float]) -> MeshBuilder:
    xmin, ymin, xmax, ymax = bounds
    m = GROUND_MARGIN_M
    mesh = MeshBuilder("ground")
    mesh.grid(
        (xmin - m, ymin - m, xmax + m, ymax + m), palette.GROUND_Z, palette.GROUND, GROUND_CELLS
    )
    return mesh


def build_areas(areas: Iterable[MapArea]) -> MeshBuilder:
    """Every area of the map as one mesh; kinds it does not know are skipped."""
    mesh = MeshBuilder("areas")
    areas = list(areas)
    ponds = [open_outline(a.polygon) for a in areas if a.kind == "water"]
    for area in areas:
        outline = open_outline(area.polygon)
        if len(outline) < 3:
            continue
        if area.kind == "junction":
            mesh.polygon(outline, palette.JUNCTION_Z, palette.JUNCTION)
        elif area.kind == "building":
            mesh.prism(outline, 0.0, building_height(area.id), palette.BUILDING)
        elif area.kind == "water":
            mesh.polygon(outline, palette.WATER_Z, palette.WATER)
        elif area.kind == "vegetation":
            mesh.polygon(outline, palette.JUNCTION_Z, palette.VEGETATION)
            for x, y in tree_spots(outline):
                if not any(inside_polygon(pond, x, y) for pond in ponds):  # no trees in a pond
                    _tree(mesh, x, y)
    return mesh


def building_height(area_id: str) -> float:
    """A stable height for a building [m], from its id."""
    lo, hi = BUILDING_HEIGHT_M
    return lo + (zlib.crc32(area_id.encode()) % 1000) / 1000 * (hi - lo)


def tree_spots(outline: Sequence[Point2]) -> list[Point2]:
    """Grid points inside the outline, at most TREE_LIMIT."""
    xs, ys = [p[0] for p in outline], [p[1] for p in outline]
    spots = []
    x = min(xs) + TREE_SPACING_M / 2
    while x < max(xs) and len(spots) < TREE_LIMIT:
        y = min(ys) + TREE_SPACING_M / 2
        while y < max(ys) and len(spots) < TREE_LIMIT:
            if inside_polygon(outline, x, y):
                spots.append((x, y))
            y += TREE_SPACING_M
        x += TREE_SPACING_M
    return spots


def _tree(mesh: MeshBuilder, x: float, y: float) -> None:
    jitter = (zlib.crc32(f"{x:.1f},{y:.1f}".encode()) % 100) / 100  # size varies a little
    mesh.box((x, y, 0.0), (0.35, 0.35, 2.5), palette.TREE_TRUNK)
    crown = 2.5 + 1.5 * jitter
    mesh.box((x, y, 2.0), (crown, crown, crown * 1.2), palette.TREE_CROWN)
