"""Buildings from the map's areas: walls with windows on every floor, doors towards the street.

Heights are not in the map, so a building gets a number of floors from its id (a stable hash:
the same map looks the same on every node), each `FLOOR_M` high. Every wall is cut into bays
of about `BAY_M` (a whole number per wall, so no window is cut at a corner) and textured one
window per bay and floor. A wall facing a street — a lane within `STREET_REACH_M` in front of
it — gets the ground-floor texture (shop windows and a door) below its first floor; other
walls carry windows down to the ground. A building's colour and the offset of its facade
pattern come from the same hash, so neighbours differ.

Lit windows: the facades carry a second texture on the stage `WINDOWS_STAGE` (mode
M_emission, which fixed-function drawing ignores and a shader reads as `p3d_TextureEmission`):
black, with the windows lit at night in a warm colour.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Sequence

import numpy as np
from panda3d.core import TextureStage

from carlaverse.messages import MapArea, MapLane
from carlaverse.render import palette
from carlaverse.render.clearance import Clearance, lane_clearance
from carlaverse.render.meshes import MeshBuilder, Point2, open_outline, polygon_area
from carlaverse.render.textures import FACADE_BAYS, FACADE_FLOORS, FLOOR_M, TextureSet

FLOORS = (2, 8)  # range of generated storeys
BAY_M = 3.2  # [m] target width of one window bay
STREET_REACH_M = 12.0  # [m] a lane this close in front of a wall makes it a street front
WINDOWS_STAGE = "windows_emission"  # the texture stage of the lit windows


def build_buildings(areas: Iterable[MapArea], lanes: Sequence[MapLane],
                    tex: TextureSet) -> list[MeshBuilder]:  # fmt: skip
    """Facades (upper floors, street-front ground floors) and roofs of every building."""
    stage = windows_stage()
    upper = MeshBuilder("facades", tex.facade.texture)
    ground = MeshBuilder("ground_floors", tex.ground_floor.texture)
    for mesh, lit in ((upper, tex.facade_lit), (ground, tex.ground_floor_lit)):
        if lit is not None:
            mesh.add_texture(stage, lit)
    roofs = MeshBuilder("roofs", tex.roof.texture, tex.roof.tile_m)
    streets = lane_clearance(lane for lane in lanes if not lane.id.startswith(":"))
    for area in areas:
        outline = open_outline(area.polygon)
        if area.kind == "building" and len(outline) >= 3:
            building = Building(area.id, outline)
            roofs.polygon(outline, building.height_m, tex.roof.tint(palette.ROOF))
            for a, b in building.walls():
                front = _faces_street(a, b, streets)
                building.wall(upper, ground if front else None, a, b)
    return [upper, ground, roofs]


def windows_stage() -> TextureStage:
    stage = TextureStage(WINDOWS_STAGE)
    stage.set_mode(TextureStage.M_emission)
    stage.set_sort(10)  # after the facade's colour
    return stage


def storeys(area_id: str) -> int:
    """A stable number of floors for a building, from its id."""
    lo, hi = FLOORS
    return lo + zlib.crc32(area_id.encode()) % (hi - lo + 1)


class Building:
    """One building's walls, height, colour and facade offset (all stable for its id)."""

    def __init__(self, area_id: str, outline: Sequence[Point2]) -> None:
        seed = zlib.crc32(f"facade:{area_id}".encode())
        self.floors = storeys(area_id)
        self.height_m = self.floors * FLOOR_M
        colours = palette.FACADES
        self.color = colours[seed % len(colours)]
        self.bay_offset = (seed >> 8) % FACADE_BAYS  # which window of the pattern comes first
        self.floor_offset = (seed >> 12) % FACADE_FLOORS
        ccw = list(outline) if polygon_area(outline) > 0 else list(reversed(outline))
        self._ccw = ccw

    def walls(self) -> list[tuple[Point2, Point2]]:
        """Each wall from corner to corner, counter-clockwise (the outside on the right)."""
        pts = self._ccw
        return [(pts[k], pts[(k + 1) % len(pts)]) for k in range(len(pts))]

    def wall(self, upper: MeshBuilder, ground: MeshBuilder | None, a: Point2, b: Point2) -> None:
        """Texture coordinates count bays along (u) and floors up (v), one repeat per
        FACADE_BAYS × FACADE_FLOORS; a street front's ground floor has its own texture."""
        length = math.dist(a, b)
        if length < 0.1:
            return
        bays = max(1, round(length / BAY_M))
        u0 = self.bay_offset / FACADE_BAYS
        u1 = u0 + bays / FACADE_BAYS
        z_split = FLOOR_M if ground is not None else 0.0
        if ground is not None:
            ground.quad((*a, 0.0), (*b, 0.0), (*b, FLOOR_M), (*a, FLOOR_M), self.color,
                        [(u0, 0.0), (u1, 0.0), (u1, 1.0), (u0, 1.0)])  # fmt: skip
        v0 = (self.floor_offset * FLOOR_M + z_split) / (FACADE_FLOORS * FLOOR_M)
        v1 = (self.floor_offset * FLOOR_M + self.height_m) / (FACADE_FLOORS * FLOOR_M)
        upper.quad((*a, z_split), (*b, z_split), (*b, self.height_m), (*a, self.height_m),
                   self.color, [(u0, v0), (u1, v0), (u1, v1), (u0, v1)])  # fmt: skip


def _faces_street(a: Point2, b: Point2, streets: Clearance) -> bool:
    """Whether a lane lies within STREET_REACH_M in front of the wall's middle."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    length = math.hypot(dx, dy) or 1.0
    nx, ny = dy / length, -dx / length  # outward: right of a → b on a counter-clockwise outline
    mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
    steps = np.linspace(0.5, STREET_REACH_M, 24)
    return bool((streets.distance(mx + nx * steps, my + ny * steps) <= 0.0).any())
