"""Road paint from the map's lanes: edge lines, lane lines, centre lines, stop and give-way
lines, zebra crossings — following SUMO's lane rules, drawn to Germany's RMS dimensions.

Lanes are numbered as in SUMO (`<edge>_<index>`, index 0 rightmost). Per road or bike lane
(internal junction lanes carry no paint, as on real junctions):

- its right edge gets a solid edge line (0.12 m) when no vehicle lane lies to its right;
- the boundary with the lane on its left, drawn once by the lower lane: dashed where a
  passenger car may change lanes both ways (`change_left` of the lower, `change_right` of
  the upper lane), solid where neither may, and a solid line beside a dashed one where only
  one side may (the dashes on the side allowed to cross); between a car lane and a bike
  lane, a broad solid line (0.25 m);
- its left edge, with no lane of its edge beyond: the centre line — dashed where the lane
  has an oncoming lane it may overtake through (SUMO `neigh`, `MapLane.opposite`; drawn once,
  by the lane of the pair whose id sorts first, so the dashes of the two directions line up),
  solid where it has none (each direction paints its half, one line 0.12 m wide centred on
  the boundary); with no lane beyond at all, a solid edge line (a one-way road's left edge);
- its end: a stop line (0.30 m deep) where a signal or a stop sign rules it, a give-way line
  (dashes of 0.50 m, gaps of 0.25 m) where it must yield.

Dashed lines: 3 m of paint, 6 m of gap up to 50 km/h, 6 m and 12 m above (RMS Leitlinie).
Zebra crossings: bars the crossing's full width, 0.50 m with 0.50 m gaps along the walk.
An edge line lies inside its lane (its outer side on the edge); a line between two lanes is
centred on their boundary.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from carlaverse.messages import MapLane, MapLight
from carlaverse.render import palette
from carlaverse.render.clearance import Clearance, lane_clearance
from carlaverse.render.meshes import (
    MeshBuilder,
    Point2,
    dashes,
    line_length,
    offset_line,
    sub_line,
)
from carlaverse.render.scene_roads import lanes_by_edge, neighbour
from carlaverse.render.textures import TextureSet

LINE_WIDTH_M = 0.12  # [m] a narrow line (edge, lane and centre lines)
BROAD_LINE_M = 0.25  # [m] a broad line (bike lane boundary)
DOUBLE_GAP_M = 0.12  # [m] between the two lines of a one-sided (solid + dashed) boundary
TOWN_DASH_M = (3.0, 6.0)  # [m] paint, gap: dashed lines up to TOWN_SPEED_MPS
RURAL_DASH_M = (6.0, 12.0)  # [m] paint, gap: faster roads
TOWN_SPEED_MPS = 50 / 3.6 + 0.01  # [m/s] 50 km/h (SUMO writes 13.89)
ZEBRA_ON_M, ZEBRA_OFF_M = 0.5, 0.5  # [m] zebra bars and gaps along the walking direction
STOP_LINE_M = 0.30  # [m] the stop line's depth
GIVE_WAY_M = (0.5, 0.25)  # [m] paint, gap of the give-way line across the lane
STOP_RULES = ("signal", "stop", "allway_stop")
MARKED_KINDS = ("road", "bike")
# All paint lies above the highest of the surfaces it is painted on: a crossing's asphalt is
# above the road lanes it crosses, and paint level with it would z-fight in an order that
# differs from run to run (the surfaces are different meshes).
PAINT_Z = (
    max(palette.LANE_Z[k] for k in ("road", "bike", "crossing", "rail")) + palette.MARKING_LIFT
)


def build_markings(lanes: Sequence[MapLane], lights: Sequence[MapLight],
                   tex: TextureSet) -> MeshBuilder:  # fmt: skip
    """All road paint as one mesh."""
    lanes = [lane for lane in lanes if len(lane.centerline) >= 2 and lane.width > 0]
    edges = lanes_by_edge(lanes)
    roads = lane_clearance(lane for e in edges.values() for lane in e.values()
                           if lane.kind in MARKED_KINDS)  # fmt: skip
    paint = Paint(MeshBuilder("markings", tex.paint.texture, tex.paint.tile_m),
                  tex.paint.tint(palette.MARKING), roads)  # fmt: skip
    signalised = {lane_id for light in lights for lane_id in light.controlled_lanes}
    for lane in lanes:
        if lane.kind == "crossing":
            _zebra(paint, lane)
        elif lane.kind in MARKED_KINDS and not lane.id.startswith(":"):
            _lane_lines(paint, lane, edges)
            rule = "signal" if lane.id in signalised else lane.right_of_way
            _end_line(paint, lane, rule)
    return paint.mesh


class Paint:
    """Where lines go: flat strips at PAINT_Z."""

    def __init__(self, mesh: MeshBuilder, color: tuple[float, float, float, float],
                 roads: Clearance) -> None:  # fmt: skip
        self.mesh, self.color = mesh, color
        self.roads = roads  # to tell a centre line from a one-way road's left edge

    def line(self, line: Sequence[Point2], width: float) -> None:
        self.mesh.strip(line, width, PAINT_Z, self.color)

    def dashed(self, line: Sequence[Point2], width: float,
               pattern: tuple[float, float]) -> None:  # fmt: skip
        for piece in dashes(line, *pattern):
            self.line(piece, width)


def dash_pattern(lane: MapLane) -> tuple[float, float]:
    """Paint and gap of a dashed line on this lane [m]."""
    return TOWN_DASH_M if lane.speed <= TOWN_SPEED_MPS else RURAL_DASH_M


def _lane_lines(paint: Paint, lane: MapLane, edges: dict[str, dict[int, MapLane]]) -> None:
    right, left = neighbour(lane, edges, -1), neighbour(lane, edges, +1)
    if right is None or right.kind not in MARKED_KINDS:
        paint.line(_inside(lane, -1, LINE_WIDTH_M), LINE_WIDTH_M)
    if left is None or left.kind not in MARKED_KINDS:
        _centre_line(paint, lane)
    elif left.kind != lane.kind:
        paint.line(_inside(lane, +1, BROAD_LINE_M), BROAD_LINE_M)
    else:
        _boundary(paint, lane, lane.change_left, left.change_right)


def _centre_line(paint: Paint, lane: MapLane) -> None:
    """The lane's left edge where its edge has no lane beyond: a centre line or an edge line."""
    if lane.opposite:
        if lane.id < lane.opposite:
            edge = offset_line(lane.centerline, lane.width / 2)
            paint.dashed(edge, LINE_WIDTH_M, dash_pattern(lane))
    elif _oncoming_beside(paint.roads, lane):
        paint.line(_inside(lane, +1, LINE_WIDTH_M / 2), LINE_WIDTH_M / 2)
    else:
        paint.line(_inside(lane, +1, LINE_WIDTH_M), LINE_WIDTH_M)


def _oncoming_beside(roads: Clearance, lane: MapLane) -> bool:
    """Whether another lane lies just beyond the lane's left edge, halfway along it."""
    half = line_length(lane.centerline) / 2
    piece = sub_line(lane.centerline, max(0.0, half - 0.5), half + 0.5)
    if len(piece) < 2:
        return False
    beyond = offset_line(piece, lane.width / 2 + 0.3)
    x, y = beyond[len(beyond) // 2]
    return roads.at(x, y) <= 0.0


def _boundary(paint: Paint, lane: MapLane, up: bool, down: bool) -> None:
    """The line between `lane` and the same-kind lane on its left; `up`: a car may cross it
    leftwards (from `lane`), `down`: rightwards (from the other lane)."""
    edge = offset_line(lane.centerline, lane.width / 2)
    pattern = dash_pattern(lane)
    if up and down:
        paint.dashed(edge, LINE_WIDTH_M, pattern)
    elif not up and not down:
        paint.line(edge, LINE_WIDTH_M)
    else:  # solid on the side that may not cross, dashes on the side that may
        shift = (LINE_WIDTH_M + DOUBLE_GAP_M) / 2
        solid, dashed = (-shift, shift) if not up else (shift, -shift)
        paint.line(offset_line(edge, solid), LINE_WIDTH_M)
        paint.dashed(offset_line(edge, dashed), LINE_WIDTH_M, pattern)


def _inside(lane: MapLane, side: int, width: float) -> list[Point2]:
    """The centre of a line `width` wide lying inside the lane along its left (+1) or right
    (−1) edge."""
    return offset_line(lane.centerline, side * (lane.width / 2 - width / 2))


def _end_line(paint: Paint, lane: MapLane, rule: str) -> None:
    """A line across the lane's last metres where it must stop or give way."""
    length = line_length(lane.centerline)
    depth = min(STOP_LINE_M, length)
    if rule in STOP_RULES:
        paint.line(sub_line(lane.centerline, length - depth, length), lane.width)
    elif rule == "yield":
        _give_way(paint, lane, sub_line(lane.centerline, length - depth, length)[-2:], depth)


def _give_way(paint: Paint, lane: MapLane, end: Sequence[Point2], depth: float) -> None:
    """Dashes across the lane, `depth` deep, ending at the lane's end (`end`: its last
    segment)."""
    (x0, y0), (x1, y1) = end
    norm = max(1e-9, math.hypot(x1 - x0, y1 - y0))
    dx, dy = (x1 - x0) / norm * depth / 2, (y1 - y0) / norm * depth / 2  # half the depth
    cx, cy, half = x1 - dx, y1 - dy, lane.width / 2 / (depth / 2)
    across = [(cx + dy * half, cy - dx * half), (cx - dy * half, cy + dx * half)]
    for piece in dashes(across, *GIVE_WAY_M):
        (ax, ay), (bx, by) = piece[0], piece[-1]
        mx, my = (ax + bx) / 2, (ay + by) / 2
        paint.line([(mx - dx, my - dy), (mx + dx, my + dy)], math.hypot(bx - ax, by - ay))


def _zebra(paint: Paint, lane: MapLane) -> None:
    for bar in dashes(lane.centerline, ZEBRA_ON_M, ZEBRA_OFF_M):
        paint.line(bar, lane.width)
