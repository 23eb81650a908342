"""Land from the map's areas: the ground, parks and water (buildings and trees have rooms of
their own: `scene_buildings`, `scene_trees`).

The ground reaches `GROUND_MARGIN_M` beyond the map, cut into cells so that per-vertex fog has
vertices near the eye; it and the parks share one grass texture (parks tinted greener). The
ground is a mesh per tile (`GROUND_TILES` per side), so the tiles out of the camera's view are
culled instead of every vertex of the ground being lit each frame (it was half the vertices
the cpu preset lit in bench_render's view).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from carlaverse.messages import MapArea
from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, open_outline
from carlaverse.render.textures import TextureSet

GROUND_MARGIN_M = 200.0  # [m] the ground plane reaches this far beyond the map
GROUND_CELLS = 80  # per side: fog is per vertex, so the ground needs vertices near the eye
GROUND_TILES = 4  # per side; divides GROUND_CELLS: the tiles' cells are the ground's cells
MEADOW_SHADE = 0.12  # ± share of brightness the ground's large patches vary by


def build_land(bounds: tuple[float, float, float, float], areas: Iterable[MapArea],
               tex: TextureSet) -> list[MeshBuilder]:  # fmt: skip
    """Grass (the ground and every park) and water; kinds it does not know are skipped."""
    grass = MeshBuilder("grass", tex.grass.texture, tex.grass.tile_m)
    water = MeshBuilder("water")
    for area in areas:
        outline = open_outline(area.polygon)
        if len(outline) < 3:
            continue
        if area.kind == "water":
            water.polygon(outline, palette.WATER_Z, palette.WATER)
        elif area.kind == "vegetation":
            grass.polygon(outline, palette.JUNCTION_Z, tex.grass.tint(palette.VEGETATION))
    return [*ground(bounds, tex), grass, water]


def ground(bounds: tuple[float, float, float, float], tex: TextureSet) -> list[MeshBuilder]:
    """The ground under and around the map, a mesh per tile."""
    xmin, ymin, xmax, ymax = bounds
    m, n = GROUND_MARGIN_M, GROUND_TILES
    x0, y0, x1, y1 = xmin - m, ymin - m, xmax + m, ymax + m
    # a tile's edges are computed the same way for both tiles that share them
    xs = [x0 + i * (x1 - x0) / n for i in range(n)] + [x1]
    ys = [y0 + j * (y1 - y0) / n for j in range(n)] + [y1]
    tiles = []
    for i in range(n):
        for j in range(n):
            tile = MeshBuilder(f"ground/{i}-{j}", tex.grass.texture, tex.grass.tile_m)
            tile.box_bounds = True
            tile.grid((xs[i], ys[j], xs[i + 1], ys[j + 1]), palette.GROUND_Z,
                      tex.grass.tint(palette.GROUND), GROUND_CELLS // n, meadow)  # fmt: skip
            tiles.append(tile)
    return tiles


def meadow(x: float, y: float) -> float:
    """Brightness of the ground at (x, y): broad, irregular patches (incommensurate waves,
    tens of metres across) that hide the grass texture's repeat at a distance."""
    wave = (math.sin(x / 23.0 + 1.3) * math.sin(y / 31.0 + 0.4)
            + 0.6 * math.sin((x + 0.7 * y) / 13.7) * math.cos((y - 0.4 * x) / 17.3))  # fmt: skip
    return 1.0 + MEADOW_SHADE * wave / 1.6
