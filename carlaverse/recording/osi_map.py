"""The recorded map (`authority/map`) as ASAM OSI lanes, lane boundaries and traffic lights.

OSI's global frame is the map's own (x east, y north, z up; right-handed), so coordinates
pass through unchanged; the map is flat, so every z is 0 on the road.

Lanes: a map lane is one OSI `Lane` whose centre line is the lane's, in its driving direction
(SUMO lanes are directed); junction-internal lanes (SUMO ids starting with `:`) are
`TYPE_INTERSECTION`. Each lane gets its own left and right `LaneBoundary`, the centre line
offset by half its width; the map carries no markings, so a boundary between two lanes of one
road is dashed where a lane change across it is allowed and solid where not, and any other
boundary's marking is `TYPE_UNKNOWN`. Neighbours are read from SUMO's lane ids
(`<edge>_<index>`, index 0 the rightmost lane).

Traffic lights: OSI's `TrafficLight` is one bulb. Each link of a signal (one character of its
SUMO state string, `MapLight.controlled_lanes`) is a three-bulb head (red, yellow, green)
at the stop line, the end of the lane it controls, facing the traffic that approaches it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from osi3.osi_lane_pb2 import Lane, LaneBoundary
from osi3.osi_trafficlight_pb2 import TrafficLight

from carlaverse import messages as m
from carlaverse.traffic.polyline import offset_right

Color = TrafficLight.Classification.Color
Mode = TrafficLight.Classification.Mode

# map lane kind -> (OSI lane type, subtype)
LANE_TYPES: dict[str, tuple[int, int]] = {
    "road": (Lane.Classification.TYPE_DRIVING, Lane.Classification.SUBTYPE_NORMAL),
    "bike": (Lane.Classification.TYPE_NONDRIVING, Lane.Classification.SUBTYPE_BIKING),
    "sidewalk": (Lane.Classification.TYPE_NONDRIVING, Lane.Classification.SUBTYPE_SIDEWALK),
    "crossing": (Lane.Classification.TYPE_NONDRIVING, Lane.Classification.SUBTYPE_OTHER),
    "walkingarea": (Lane.Classification.TYPE_NONDRIVING, Lane.Classification.SUBTYPE_OTHER),
    "rail": (Lane.Classification.TYPE_NONDRIVING, Lane.Classification.SUBTYPE_OTHER),
}
BULBS = (Color.COLOR_RED, Color.COLOR_YELLOW, Color.COLOR_GREEN)  # top to bottom
BULB_SIZE_M = 0.3  # [m] a signal lens, each way
BULB_TOP_Z_M = 3.0  # [m] height of the red bulb's centre; the others below it
# SUMO signal state character -> which bulbs are lit, and how (SUMO "Traffic Lights",
# signal state definitions): r red; y amber; g, G, s green (minor, priority, stop-then-go);
# u red and amber together (about to turn green); o off but blinking amber; O off.
_LIT: dict[str, dict[int, int]] = {
    "r": {Color.COLOR_RED: Mode.MODE_CONSTANT},
    "y": {Color.COLOR_YELLOW: Mode.MODE_CONSTANT},
    "g": {Color.COLOR_GREEN: Mode.MODE_CONSTANT},
    "G": {Color.COLOR_GREEN: Mode.MODE_CONSTANT},
    "s": {Color.COLOR_GREEN: Mode.MODE_CONSTANT},
    "u": {Color.COLOR_RED: Mode.MODE_CONSTANT, Color.COLOR_YELLOW: Mode.MODE_CONSTANT},
    "o": {Color.COLOR_YELLOW: Mode.MODE_FLASHING},
    "O": {},
}


class OsiIds:
    """Stable OSI identifiers (uint64, unique within a ground truth) for named things."""

    def __init__(self) -> None:
        self._ids: dict[tuple[str, str], int] = {}

    def of(self, family: str, name: str) -> int:
        return self._ids.setdefault((family, name), len(self._ids) + 1)

    def get(self, family: str, name: str) -> int | None:
        return self._ids.get((family, name))


def _edge_index(lane_id: str) -> tuple[str, int] | None:
    edge, _, index = lane_id.rpartition("_")
    return (edge, int(index)) if edge and index.isdigit() else None


def _neighbour(lane: m.MapLane, step: int, by_id: dict[str, m.MapLane]) -> m.MapLane | None:
    """The lane `step` to the left (+1) or right (-1) of `lane` on the same road, if any."""
    parsed = _edge_index(lane.id)
    if parsed is None:
        return None
    other = by_id.get(f"{parsed[0]}_{parsed[1] + step}")
    return other if other is not None and other.kind == lane.kind else None


def _line_type(lane: m.MapLane, side: int, by_id: dict[str, m.MapLane]) -> int:
    types = LaneBoundary.Classification
    if _neighbour(lane, side, by_id) is None:
        return types.TYPE_UNKNOWN
    may_change = lane.change_left if side > 0 else lane.change_right
    return types.TYPE_DASHED_LINE if may_change else types.TYPE_SOLID_LINE


def lanes(road_map: m.MapReply, ids: OsiIds) -> tuple[list[Lane], list[LaneBoundary]]:
    """Every map lane with two centre-line points or more, and its two boundaries."""
    by_id = {lane.id: lane for lane in road_map.lanes if len(lane.centerline) >= 2}
    out_lanes, out_boundaries = [], []
    for lane in by_id.values():
        out_lanes.append(_lane(lane, by_id, ids))
        for side in (+1, -1):  # left, right
            out_boundaries.append(_boundary(lane, side, by_id, ids))
    return out_lanes, out_boundaries


def _lane(lane: m.MapLane, by_id: dict[str, m.MapLane], ids: OsiIds) -> Lane:
    out = Lane()
    out.id.value = ids.of("lane", lane.id)
    c = out.classification
    c.type, c.subtype = LANE_TYPES.get(lane.kind, (Lane.Classification.TYPE_OTHER, 0))
    if lane.id.startswith(":") and lane.kind == "road":  # SUMO: a lane inside a junction
        c.type = Lane.Classification.TYPE_INTERSECTION
    for x, y in lane.centerline:
        point = c.centerline.add()
        point.x, point.y, point.z = x, y, 0.0
    c.centerline_is_driving_direction = True
    c.left_lane_boundary_id.add().value = ids.of("boundary", f"{lane.id}/left")
    c.right_lane_boundary_id.add().value = ids.of("boundary", f"{lane.id}/right")
    for step, field in ((+1, c.left_adjacent_lane_id), (-1, c.right_adjacent_lane_id)):
        other = _neighbour(lane, step, by_id)
        if other is not None:
            field.add().value = ids.of("lane", other.id)
    for successor in dict.fromkeys(lane.successors):
        if successor in by_id:
            c.lane_pairing.add().successor_lane_id.value = ids.of("lane", successor)
    return out


def _boundary(lane: m.MapLane, side: int, by_id: dict[str, m.MapLane], ids: OsiIds) -> LaneBoundary:
    out = LaneBoundary()
    out.id.value = ids.of("boundary", f"{lane.id}/{'left' if side > 0 else 'right'}")
    # offset_right is to the right for a positive offset: the left edge is -width/2
    for x, y in offset_right(lane.centerline, -side * lane.width / 2):
        point = out.boundary_line.add()
        point.position.x, point.position.y, point.position.z = x, y, 0.0
    out.classification.type = _line_type(lane, side, by_id)
    return out


@dataclass(frozen=True, slots=True)
class SignalHead:
    """One link of a signal: where its head stands and the OSI ids of its three bulbs."""

    light_id: str  # the map's (SUMO tls) id
    link: int  # index into the signal's state string
    x: float  # [m] stop line
    y: float  # [m]
    facing: float  # [rad] the way its lenses face (against the approaching traffic)
    lane_id: int | None  # OSI id of the lane it controls
    bulb_ids: tuple[int, int, int]  # red, yellow, green


def signal_heads(road_map: m.MapReply, ids: OsiIds) -> list[SignalHead]:
    by_id = {lane.id: lane for lane in road_map.lanes if len(lane.centerline) >= 2}
    heads = []
    for light in road_map.lights:
        for link, lane_id in enumerate(light.controlled_lanes):
            lane = by_id.get(lane_id)
            if lane is None:
                x, y, facing = light.position[0], light.position[1], 0.0
            else:
                (ax, ay), (x, y) = lane.centerline[-2], lane.centerline[-1]
                facing = math.atan2(y - ay, x - ax) + math.pi
            bulbs = tuple(ids.of("bulb", f"{light.id}/{link}/{c}") for c in range(3))
            lane_osi = ids.of("lane", lane_id) if lane is not None else None
            heads.append(SignalHead(light.id, link, x, y, facing, lane_osi, bulbs))  # type: ignore[arg-type]
    return heads


def bulb_modes(state_char: str) -> list[int]:
    """The mode of the red, yellow and green bulb for one SUMO state character."""
    lit = _LIT.get(state_char)
    if lit is None:
        return [Mode.MODE_UNKNOWN] * 3
    return [lit.get(color, Mode.MODE_OFF) for color in BULBS]


def traffic_lights(heads: Iterable[SignalHead], states: dict[str, str]) -> list[TrafficLight]:
    """Every bulb of the heads whose signal has a known state (`states`: id -> SUMO string)."""
    out = []
    for head in heads:
        state = states.get(head.light_id)
        if state is None:
            continue
        char = state[head.link] if head.link < len(state) else "?"
        for k, (color, mode) in enumerate(zip(BULBS, bulb_modes(char), strict=True)):
            out.append(_bulb(head, k, color, mode))
    return out


def _bulb(head: SignalHead, k: int, color: int, mode: int) -> TrafficLight:
    bulb = TrafficLight()
    bulb.id.value = head.bulb_ids[k]
    base = bulb.base
    base.position.x, base.position.y = head.x, head.y
    base.position.z = BULB_TOP_Z_M - k * BULB_SIZE_M
    base.orientation.yaw = math.remainder(head.facing, 2 * math.pi)
    base.dimension.length = base.dimension.width = base.dimension.height = BULB_SIZE_M
    bulb.classification.color = color
    bulb.classification.icon = TrafficLight.Classification.ICON_NONE
    bulb.classification.mode = mode
    if head.lane_id is not None:
        bulb.classification.assigned_lane_id.add().value = head.lane_id
    bulb.source_reference.add().identifier.extend([head.light_id, str(head.link)])
    return bulb
