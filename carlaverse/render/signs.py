"""Which traffic signs stand where, from the map's lanes (no drawing here: `scene_signs`).

- Speed limit (a round sign with the number in km/h, SUMO's lane speed × 3.6 rounded): at the
  start of an edge whose limit differs from that of an edge leading into it, or that nothing
  but its own U-turn leads into (where traffic enters the map), `SPEED_SIGN_AFTER_M` along it.
- Stop (octagon) where a lane's right of way is `stop` or `allway_stop`, give way (inverted
  triangle) where it is `yield`: `END_SIGN_BEFORE_M` before the edge's end.

Signs stand on the right of the road (right-hand traffic): the pole `SETBACK_M` beyond the
right edge of the edge's rightmost vehicle lane, the face turned towards the traffic it
addresses. Edges are SUMO's: lanes `<edge>_<index>`, index 0 rightmost; internal junction
lanes carry no signs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from carlaverse.messages import MapLane
from carlaverse.render.meshes import Point2, line_length, offset_line, sub_line
from carlaverse.render.scene_roads import edge_and_index, lanes_by_edge

SETBACK_M = 0.7  # [m] from the road's edge to the pole (the 0.6 m face clears the road)
SPEED_SIGN_AFTER_M = 6.0  # [m] from an edge's start
END_SIGN_BEFORE_M = 1.0  # [m] before an edge's end (beside the stop line)
U_TURN_RAD = math.radians(150)  # a link that turns more than this is a U-turn
SIGNED_KINDS = ("road",)  # bike paths and rails carry no car signs
END_SIGNS = {"stop": "stop", "allway_stop": "stop", "yield": "yield"}


@dataclass(frozen=True, slots=True)
class Sign:
    kind: str  # speed | stop | yield
    x: float  # [m] the pole
    y: float  # [m]
    facing: float  # [rad] the direction the face looks (against the traffic's heading)
    edge: str  # the SUMO edge it is for
    kmh: int = 0  # a speed sign's limit [km/h]


def place_signs(lanes: Sequence[MapLane]) -> list[Sign]:
    """Every speed, stop and give-way sign the map calls for, sorted by edge."""
    edges = {
        edge: by_index
        for edge, by_index in lanes_by_edge(lanes).items()
        if any(lane.kind in SIGNED_KINDS for lane in by_index.values())
    }
    speeds = {edge: edge_speed(by_index) for edge, by_index in edges.items()}
    feeders = _feeders(edges)
    signs = []
    for edge in sorted(edges):
        road = _rightmost(edges[edge])
        if speeds[edge] > 0 and _limit_changes(edge, edges, speeds, feeders):
            signs.append(_beside(road, SPEED_SIGN_AFTER_M, "speed", edge, kmh(speeds[edge])))
        rules = {END_SIGNS.get(lane.right_of_way) for lane in edges[edge].values()} - {None}
        for kind in sorted(r for r in rules if r is not None):
            length = line_length(road.centerline)
            signs.append(_beside(road, max(0.0, length - END_SIGN_BEFORE_M), kind, edge))
    return signs


def kmh(speed_mps: float) -> int:
    """A speed limit as a sign shows it [km/h]."""
    return round(speed_mps * 3.6)


def edge_speed(by_index: dict[int, MapLane]) -> float:
    """[m/s] the limit for cars on an edge: the highest of its road lanes'."""
    return max((lane.speed for lane in by_index.values() if lane.kind in SIGNED_KINDS), default=0.0)


def _rightmost(by_index: dict[int, MapLane]) -> MapLane:
    return by_index[min(i for i, lane in by_index.items() if lane.kind in SIGNED_KINDS)]


def _feeders(edges: dict[str, dict[int, MapLane]]) -> dict[str, set[str]]:
    """Per edge, the edges whose lanes lead into it."""
    feeders: dict[str, set[str]] = {}
    for edge, by_index in edges.items():
        for lane in by_index.values():
            for successor in lane.successors:
                split = edge_and_index(successor)
                if split is not None and split[0] in edges:
                    feeders.setdefault(split[0], set()).add(edge)
    return feeders


def _limit_changes(edge: str, edges: dict[str, dict[int, MapLane]], speeds: dict[str, float],
                   feeders: dict[str, set[str]]) -> bool:  # fmt: skip
    """Whether traffic arrives on `edge` from a different limit, or enters the map here."""
    start = _heading(_rightmost(edges[edge]).centerline, at_end=False)
    ahead = [
        f for f in feeders.get(edge, ())
        if _turn(_heading(_rightmost(edges[f]).centerline, at_end=True), start) < U_TURN_RAD
    ]  # fmt: skip
    return not ahead or any(kmh(speeds[f]) != kmh(speeds[edge]) for f in ahead)


def _heading(line: Sequence[Point2], at_end: bool) -> float:
    (x0, y0), (x1, y1) = (line[-2], line[-1]) if at_end else (line[0], line[1])
    return math.atan2(y1 - y0, x1 - x0)


def _turn(a: float, b: float) -> float:
    return abs((b - a + math.pi) % math.tau - math.pi)


def _beside(lane: MapLane, s: float, kind: str, edge: str, value: int = 0) -> Sign:
    """A sign at arc length `s` along the lane, SETBACK_M beyond its right edge."""
    s = min(s, line_length(lane.centerline))
    piece = sub_line(lane.centerline, max(0.0, s - 0.5), s + 0.5)
    heading = _heading(piece, at_end=True) if len(piece) >= 2 else 0.0
    here = sub_line(lane.centerline, s, s)[0]
    right = offset_line([here, (here[0] + math.cos(heading), here[1] + math.sin(heading))],
                        -(lane.width / 2 + SETBACK_M))[0]  # fmt: skip
    return Sign(kind, right[0], right[1], heading + math.pi, edge, value)
