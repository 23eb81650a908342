"""Road surfaces from the map's lanes: asphalt, sidewalks with kerbs, bike lanes, junctions.

Three meshes, one texture each (a draw call each once flattened): asphalt under every lane a
vehicle uses, the junctions and the crossings (bike lanes and rails tinted); paving for
sidewalks and walking areas, which stand a kerb's height above the road; and kerb stones —
the vertical face where a sidewalk meets the road (its lane on the left in SUMO's numbering,
`<edge>_<index>`, index 0 rightmost) and around walking areas, and a strip of kerb on top.
A sidewalk's outer side has no face: the land beside it is taken to be level with it.
The paint on top is `scene_markings`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from carlaverse.messages import MapArea, MapLane
from carlaverse.patterns import is_ascii_decimal
from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, Point2, offset_line, open_outline, polygon_area
from carlaverse.render.textures import TextureSet

KERB_TOP_M = 0.15  # [m] the kerb stone's width seen from above
PEDESTRIAN_KINDS = ("sidewalk", "walkingarea")
VEHICLE_KINDS = ("road", "bike", "rail")


def build_roads(
    lanes: Sequence[MapLane], junctions: Sequence[MapArea], tex: TextureSet
) -> list[MeshBuilder]:
    """Asphalt, paving and kerbs of every lane and junction."""
    lanes = [lane for lane in lanes if len(lane.centerline) >= 2 and lane.width > 0]
    asphalt = MeshBuilder("asphalt", tex.asphalt.texture, tex.asphalt.tile_m)
    paving = MeshBuilder("paving", tex.paving.texture, tex.paving.tile_m)
    kerbs = MeshBuilder("kerbs", tex.kerb.texture, tex.kerb.tile_m)
    for area in junctions:
        outline = open_outline(area.polygon)
        if len(outline) >= 3:
            asphalt.polygon(outline, palette.JUNCTION_Z, tex.asphalt.tint(palette.JUNCTION))
    edges = lanes_by_edge(lanes)
    for lane in lanes:
        z = palette.LANE_Z.get(lane.kind, palette.LANE_Z["road"])
        if lane.kind == "walkingarea":
            _walking_area(paving, kerbs, lane, z, tex)
        elif lane.kind == "sidewalk":
            _sidewalk(paving, kerbs, lane, z, _road_on_the_left(lane, edges), tex)
        else:
            color = palette.LANE_COLORS.get(lane.kind, palette.ASPHALT)
            asphalt.ribbon(lane.centerline, lane.width, z, tex.asphalt.tint(color))
    return [asphalt, paving, kerbs]


def edge_and_index(lane_id: str) -> tuple[str, int] | None:
    """SUMO's `<edge>_<index>` split; None for ids of another form."""
    edge, _, index = lane_id.rpartition("_")
    # ASCII digits only: `isdigit` is true for '٣' (which `int` reads as 3) and '²' (which it
    # refuses), and a map file is outside text.
    return (edge, int(index)) if edge and is_ascii_decimal(index) else None


def lanes_by_edge(lanes: Sequence[MapLane]) -> dict[str, dict[int, MapLane]]:
    """Normal (non-junction) lanes by edge and index."""
    edges: dict[str, dict[int, MapLane]] = {}
    for lane in lanes:
        split = edge_and_index(lane.id)
        if split is not None and not lane.id.startswith(":"):
            edges.setdefault(split[0], {})[split[1]] = lane
    return edges


def neighbour(lane: MapLane, edges: dict[str, dict[int, MapLane]], step: int) -> MapLane | None:
    """The lane `step` places to the left (+) or right (−) on the same edge, if any."""
    split = edge_and_index(lane.id)
    if split is None:
        return None
    return edges.get(split[0], {}).get(split[1] + step)


def _road_on_the_left(lane: MapLane, edges: dict[str, dict[int, MapLane]]) -> bool:
    left = neighbour(lane, edges, +1)
    return left is not None and left.kind in VEHICLE_KINDS


def _sidewalk(paving: MeshBuilder, kerbs: MeshBuilder, lane: MapLane, z: float, kerb: bool,
              tex: TextureSet) -> None:  # fmt: skip
    """Paving; with a road on its left, a kerb: the stone along that edge (beside the paving,
    not over it, so nothing is coplanar) and its face down to the road."""
    color = tex.paving.tint(palette.SIDEWALK)
    if not kerb or lane.width <= 2 * KERB_TOP_M:
        paving.ribbon(lane.centerline, lane.width, z, color)
        return
    paving.ribbon(offset_line(lane.centerline, -KERB_TOP_M / 2), lane.width - KERB_TOP_M, z, color)
    stone = tex.kerb.tint(palette.KERB)
    kerbs.strip(offset_line(lane.centerline, (lane.width - KERB_TOP_M) / 2), KERB_TOP_M, z, stone)
    edge = offset_line(lane.centerline, lane.width / 2)
    _faces(kerbs, list(reversed(edge)), palette.GROUND_Z, z, stone)  # reversed: facing left


def _walking_area(
    paving: MeshBuilder, kerbs: MeshBuilder, lane: MapLane, z: float, tex: TextureSet
) -> None:
    """A walking area's outline filled (SUMO gives its polygon as the lane's shape)."""
    outline = open_outline(lane.centerline)
    color = tex.paving.tint(palette.WALKINGAREA)
    before = paving.triangles
    if len(outline) >= 3:
        paving.polygon(outline, z, color)
    if paving.triangles == before:  # not a polygon (or one the triangulator refused)
        paving.ribbon(lane.centerline, lane.width, z, color)
        return
    ccw = outline if polygon_area(outline) > 0 else list(reversed(outline))
    _faces(kerbs, [*ccw, ccw[0]], palette.GROUND_Z, z, tex.kerb.tint(palette.KERB))


def _faces(mesh: MeshBuilder, line: Sequence[Point2], z0: float, z1: float,
           color: tuple[float, float, float, float]) -> None:  # fmt: skip
    """Vertical faces along a polyline, each facing right of its direction, textured from
    the start of the line along its length."""
    walked = 0.0
    for a, b in itertools.pairwise(line):
        mesh.wall(a, b, z0, z1, color, u0=walked)
        walked += math.dist(a, b)
