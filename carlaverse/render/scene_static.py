"""The static scene of a map, built once: road surfaces and paint, land, buildings, trees, signs.

`Renderer._build_map` attaches `road` under the node wetness darkens and `land` beside it.
Each entry is one mesh with one texture state, so the map costs a draw call per entry: about
a dozen, one per 100 m square that has trees and one per tile of the ground in view (squares
and tiles out of view are culled). Everything
random is seeded by the map's name, so every node that draws the same map draws the same trees
and facades.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

from carlaverse.messages import MapReply
from carlaverse.render.meshes import MeshBuilder
from carlaverse.render.scene_areas import build_land
from carlaverse.render.scene_buildings import build_buildings
from carlaverse.render.scene_markings import build_markings
from carlaverse.render.scene_roads import build_roads
from carlaverse.render.scene_signs import build_signs
from carlaverse.render.scene_trees import build_trees, plant
from carlaverse.render.signs import place_signs
from carlaverse.render.textures import texture_set


@dataclass(frozen=True, slots=True)
class StaticScene:
    road: list[MeshBuilder]  # asphalt, paving, kerbs, paint: what rain darkens
    land: list[MeshBuilder]  # grass, water, facades, roofs, trees, signs


def build_static(
    road_map: MapReply | None, bounds: tuple[float, float, float, float], textured: bool = True
) -> StaticScene:
    """The meshes of `road_map` (only the ground without one); `textured=False` draws every
    surface in its palette colour (no asphalt grain, paving, windows), the cheapest picture."""
    tex = texture_set(plain=not textured)
    if road_map is None:
        return StaticScene([], build_land(bounds, [], tex))
    seed = zlib.crc32(road_map.name.encode())
    lanes, areas = road_map.lanes, road_map.areas
    junctions = [a for a in areas if a.kind == "junction"]
    road = [*build_roads(lanes, junctions, tex), build_markings(lanes, road_map.lights, tex)]
    land = [
        *build_land(bounds, areas, tex),
        *build_buildings(areas, lanes, tex),
        *build_trees(plant(areas, lanes, seed), seed),
        build_signs(place_signs(lanes)),
    ]
    return StaticScene(road, land)
