"""Road surfaces from the map's lanes: lanes with markings, sidewalks, bike lanes, crossings.

Lane markings follow SUMO's lane numbering (`<edge>_<index>`, index 0 rightmost): a lane's
right edge is a solid line when it is the edge's rightmost lane, and its left edge is dashed
when the edge has a lane further left, solid otherwise. Internal junction lanes (ids that
start with ':') carry no markings, as on real junctions. Crossings are zebra stripes: white
bars the crossing's full width, alternating along the walking direction.
"""

from __future__ import annotations

from collections.abc import Iterable

from carlaverse.messages import MapLane
from carlaverse.patterns import is_ascii_decimal
from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, dashes, offset_line

LINE_WIDTH_M = 0.12  # [m] a lane marking
DASH_ON_M, DASH_OFF_M = 3.0, 6.0  # [m] lane-divider dashes (urban, as in Germany's StVO)
ZEBRA_ON_M, ZEBRA_OFF_M = 0.5, 0.5  # [m] zebra bars and gaps along the walking direction
STOP_LINE_M = 0.30  # [m] the stop line's depth


def build_lanes(lanes: Iterable[MapLane]) -> MeshBuilder:
    """All lane surfaces and their markings, as one mesh."""
    lanes = [lane for lane in lanes if len(lane.centerline) >= 2 and lane.width > 0]
    indices = _lane_indices(lanes)
    mesh = MeshBuilder("lanes")
    for lane in lanes:
        z = palette.LANE_Z.get(lane.kind, palette.LANE_Z["road"])
        color = palette.LANE_COLORS.get(lane.kind, palette.ASPHALT)
        mesh.ribbon(lane.centerline, lane.width, z, color)
        if lane.kind == "crossing":
            _zebra(mesh, lane, z)
        elif lane.kind in ("road", "bike") and not lane.id.startswith(":"):
            _edge_lines(mesh, lane, z, indices)
    return mesh


def _lane_indices(lanes: list[MapLane]) -> set[tuple[str, int]]:
    """Every (edge, index) pair present, to tell whether a lane has a neighbour on its left."""
    found = set()
    for lane in lanes:
        split = _edge_and_index(lane.id)
        if split is not None:
            found.add(split)
    return found


def _edge_and_index(lane_id: str) -> tuple[str, int] | None:
    edge, _, index = lane_id.rpartition("_")
    # ASCII digits only: `isdigit` is true for '٣' (which `int` reads as 3) and '²' (which it
    # refuses), and a map file is outside text.
    return (edge, int(index)) if edge and is_ascii_decimal(index) else None


def _edge_lines(mesh: MeshBuilder, lane: MapLane, z: float, indices: set[tuple[str, int]]) -> None:
    split = _edge_and_index(lane.id)
    edge, index = split if split is not None else (lane.id, 0)
    half = lane.width / 2 - LINE_WIDTH_M / 2
    z_line = z + palette.MARKING_LIFT
    if index == 0:
        mesh.ribbon(offset_line(lane.centerline, -half), LINE_WIDTH_M, z_line, palette.MARKING)
    left = offset_line(lane.centerline, half)
    if (edge, index + 1) in indices:
        for piece in dashes(left, DASH_ON_M, DASH_OFF_M):
            mesh.ribbon(piece, LINE_WIDTH_M, z_line, palette.MARKING)
    else:
        mesh.ribbon(left, LINE_WIDTH_M, z_line, palette.MARKING)


def _zebra(mesh: MeshBuilder, lane: MapLane, z: float) -> None:
    for bar in dashes(lane.centerline, ZEBRA_ON_M, ZEBRA_OFF_M):
        mesh.ribbon(bar, lane.width, z + palette.MARKING_LIFT, palette.MARKING)


def stop_line(mesh: MeshBuilder, lane: MapLane) -> None:
    """A white bar across the end of a lane that a traffic light controls."""
    line = lane.centerline
    (x0, y0), (x1, y1) = line[-2], line[-1]
    length = max(1e-6, ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5)
    u = min(1.0, STOP_LINE_M / length)
    start = (x1 - (x1 - x0) * u, y1 - (y1 - y0) * u)
    z = palette.LANE_Z.get(lane.kind, palette.LANE_Z["road"]) + 2 * palette.MARKING_LIFT
    mesh.ribbon([start, (x1, y1)], lane.width, z, palette.STOP_LINE)
