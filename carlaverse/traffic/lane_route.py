"""Routes along the map's lanes for the scripted drivers of `--backend sim` (drive and bike).

A route starts where the node was spawned, on the nearest lane of its kind heading its way
(`lane_graph`), and goes on through each junction on the junction's own internal lanes. It
first finds the way into the largest part of the network where every lane can reach every
other (so never into a dead end), then turns at random there, from a seeded generator, until
it has `min_loop_m`, and goes back by the shortest way to where that loop began: the route
closes, and a driver laps it for as long as the session runs (`Route.loop_from`).

A car keeps to the centre line of its lanes. A bike keeps to the centre of a bike lane and
to the right edge of a road lane, `BIKE_EDGE_M` from it.
"""

from __future__ import annotations

import itertools
import math
import random
from dataclasses import dataclass

from carlaverse.messages import MapLane, MapReply
from carlaverse.traffic.lane_graph import LaneGraph
from carlaverse.traffic.polyline import Point, join, offset_right, project, resample

STEP_M = 1.0  # [m] between waypoints
MIN_LOOP_M = 1500.0  # [m] a loop at least this long (2 min at 12 m/s)
BIKE_EDGE_M = 0.8  # [m] from a road lane's right edge to a rider's wheels
MAX_START_GAP_M = 10.0  # [m] a spawn further than this from every lane has no route
MAX_START_TURN_RAD = math.radians(60.0)  # [rad] the start lane heads within this of the spawn


@dataclass(frozen=True)
class Route:
    """Waypoints [m] `STEP_M` apart; after the last one the route goes on at `loop_from`."""

    waypoints: list[Point]
    loop_from: int | None  # None: the route ends (no loop could be found)
    lanes: list[str]  # the lanes it drives, in order: the way in, then the loop

    @property
    def loop_m(self) -> float:
        """[m] the length of the loop (0 without one)."""
        if self.loop_from is None:
            return 0.0
        ring = [*self.waypoints[self.loop_from :], self.waypoints[self.loop_from]]
        return sum(math.dist(a, b) for a, b in itertools.pairwise(ring))


def plan_route(reply: MapReply, kind: str, x: float, y: float, yaw: float, seed: int,
               min_loop_m: float = MIN_LOOP_M) -> Route | None:  # fmt: skip
    """A route for a `kind` (car | bike) road user at (x, y) heading `yaw` [rad]; None when
    no lane of its kind is near enough and heading its way."""
    graph = LaneGraph(reply, kind)
    start = _start_lane(graph, x, y, yaw)
    if start is None:
        return None
    rng = random.Random(seed)
    core = graph.loop_core(start)
    way_in = graph.shortest(start, core) if core else None
    if way_in is None:  # nowhere to loop: drive on at random until the road ends
        return _open_route(graph, start, rng, min_loop_m, x, y)
    loop = _random_loop(graph, way_in[-1], core, rng, min_loop_m)
    skip = project(_line(graph, graph.lanes[start]), x, y).along_m
    ring = resample(_lanes_line(graph, loop, then=loop[0]), STEP_M)[:-1]  # [-1]: ring[0]
    if len(way_in) == 1:  # spawned on the loop (its first lane): start it where it stands
        first = min(round(skip / STEP_M), len(ring) - 1)
        return Route(ring[first:] + ring[:first], 0, loop)
    lead = resample(_lanes_line(graph, way_in[:-1], then=loop[0]), STEP_M, skip)[:-1]
    return Route(lead + ring, len(lead), way_in[:-1] + loop)


def _start_lane(graph: LaneGraph, x: float, y: float, yaw: float) -> str | None:
    best, best_gap = None, MAX_START_GAP_M
    for lane_id, lane in sorted(graph.lanes.items()):
        hit = project(lane.centerline, x, y)
        turn = abs(math.remainder(hit.heading - yaw, 2 * math.pi))
        if hit.distance_m <= best_gap and turn <= MAX_START_TURN_RAD:
            best, best_gap = lane_id, hit.distance_m
    return best


def _random_loop(graph: LaneGraph, entry: str, core: set[str], rng: random.Random,
                 min_loop_m: float) -> list[str]:  # fmt: skip
    """Lanes from `entry` turning at random in `core` for `min_loop_m`, then back the
    shortest way: the last lane leads to `entry`."""
    loop, walked = [entry], graph.length[entry]
    while walked < min_loop_m:
        here = rng.choice(sorted(n for n in graph.next[loop[-1]] if n in core))
        loop.append(here)
        walked += graph.length[here]
    back = graph.shortest(loop[-1], {entry}, within=core)
    assert back is not None  # every lane of the core reaches every other
    loop += back[1:]
    if len(loop) > 1 and loop[-1] == entry:
        loop.pop()
    return loop


def _open_route(graph: LaneGraph, start: str, rng: random.Random, length_m: float,
                x: float, y: float) -> Route:  # fmt: skip
    lanes, walked = [start], 0.0
    while walked < length_m and graph.next[lanes[-1]]:
        lanes.append(rng.choice(sorted(graph.next[lanes[-1]])))
        walked += graph.length[lanes[-1]]
    skip = project(_line(graph, graph.lanes[start]), x, y).along_m
    return Route(resample(_lanes_line(graph, lanes), STEP_M, skip), None, lanes)


def _lanes_line(graph: LaneGraph, lanes: list[str], then: str | None = None) -> list[Point]:
    """The line along `lanes` and across the junctions between them; with `then`, on across
    the last junction to the first point of lane `then`."""
    pieces = []
    after_each = [*lanes[1:], then]
    for here, after in zip(lanes, after_each, strict=True):
        pieces.append(_line(graph, graph.lanes[here]))
        if after is not None:
            pieces += [_line(graph, lane) for lane in graph.crossing(here, after)]
    if then is not None:
        pieces.append(_line(graph, graph.lanes[then])[:1])
    return join(pieces)


def _line(graph: LaneGraph, lane: MapLane) -> list[Point]:
    """Where on `lane` the road user keeps: its centre, or a bike on a road its right edge."""
    if graph.kind == "bike" and lane.kind == "road":
        return offset_right(lane.centerline, max(0.0, lane.width / 2 - BIKE_EDGE_M))
    return [(float(px), float(py)) for px, py in lane.centerline]
