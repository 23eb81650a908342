"""Routes along the map's lanes for the scripted drivers: on a ring drawn by hand, where every
figure can be worked out, and on the town SUMO builds, from every spawn of the scenario."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.messages import SCHEMA_VERSION, MapLane, MapReply
from carlaverse.traffic.lane_graph import strongly_connected
from carlaverse.traffic.lane_route import Route, plan_route

WIDTH_M = 3.2  # [m] every lane of the ring
CORNER_R = 5.0  # [m] the ring's internal corner lanes: quarter circles
SIDE_M = 90.0  # [m] each straight side of the ring
RING_LAP_M = 4 * SIDE_M + 4 * math.pi / 2 * CORNER_R  # 391.4 m


def quarter(cx: float, cy: float, start_deg: float, points: int = 10) -> list:
    """A counter-clockwise quarter circle of radius CORNER_R about (cx, cy) from start_deg."""
    return [(cx + CORNER_R * math.cos(math.radians(start_deg + 90 * k / points)),
             cy + CORNER_R * math.sin(math.radians(start_deg + 90 * k / points)))
            for k in range(points + 1)]  # fmt: skip


def lane(lane_id: str, line: list, successors: list[str], kind: str = "road") -> MapLane:
    return MapLane(lane_id, kind, WIDTH_M, line, successors=successors)


def ring_map() -> MapReply:
    """A one-way ring round a 100 m block, counter-clockwise: south side eastbound (s), east
    northbound (e), north westbound (n), west southbound (w), joined by internal corner lanes;
    a street (in) from the west into s; from s's end also a street east (out) to a dead end
    whose only way on is a U-turn into a street back (back); a footway beside s."""
    lanes = [
        lane("s", [(5.0, 0.0), (95.0, 0.0)], ["e", "out"]),
        lane(":se", quarter(95, 5, -90), ["e"]),
        lane("e", [(100.0, 5.0), (100.0, 95.0)], ["n"]),
        lane(":ne", quarter(95, 95, 0), ["n"]),
        lane("n", [(95.0, 100.0), (5.0, 100.0)], ["w"]),
        lane(":nw", quarter(5, 95, 90), ["w"]),
        lane("w", [(0.0, 95.0), (0.0, 5.0)], ["s"]),
        lane(":sw", quarter(5, 5, 180), ["s"]),
        lane("in", [(-60.0, 0.0), (-5.0, 0.0)], ["s"]),
        lane(":in", [(-5.0, 0.0), (5.0, 0.0)], ["s"]),
        lane(":out", [(95.0, 0.0), (105.0, 0.0)], ["out"]),
        lane("out", [(105.0, 0.0), (160.0, 0.0)], ["back"]),
        lane(":uturn", [(160.0, 0.0), (162.0, 1.6), (160.0, 3.2)], ["back"]),
        lane("back", [(160.0, 3.2), (105.0, 3.2)], []),
        lane("foot", [(5.0, -3.0), (95.0, -3.0)], [], kind="sidewalk"),
    ]
    return MapReply(SCHEMA_VERSION, "ring", (-60.0, -5.0, 165.0, 105.0), lanes)


def gaps(route: Route) -> list[float]:
    """[m] between consecutive waypoints, and from the last back to where the loop goes on."""
    w = route.waypoints
    seam = [math.dist(w[-1], w[route.loop_from])] if route.loop_from is not None else []
    return [math.dist(a, b) for a, b in itertools.pairwise(w)] + seam


def off_lines(points: list, lines: list[list]) -> float:
    """[m] the farthest any point is from the nearest of `lines`."""

    def to_line(p: tuple, line: list) -> float:
        best = math.inf
        for (ax, ay), (bx, by) in itertools.pairwise(line):
            dx, dy = bx - ax, by - ay
            t = max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)))
            best = min(best, math.hypot(ax + t * dx - p[0], ay + t * dy - p[1]))
        return best

    return max(min(to_line(p, line) for line in lines) for p in points)


def test_a_car_enters_the_ring_and_laps_it_never_into_the_dead_end() -> None:
    road = ring_map()
    route = plan_route(road, "car", -40.0, 0.0, 0.0, seed=1, min_loop_m=1000.0)
    assert route is not None
    assert route.waypoints[0] == pytest.approx((-40.0, 0.0))  # where the car stands
    assert route.lanes[0] == "in" and set(route.lanes[1:]) == {"s", "e", "n", "w"}
    # the loop starts where the ring is entered, at s's first point
    assert route.loop_from is not None
    assert route.waypoints[route.loop_from] == pytest.approx((5.0, 0.0))
    # a loop of at least 1000 m of lanes is 3 laps of the ring's 360 m of sides
    assert route.loop_m == pytest.approx(3 * RING_LAP_M, abs=1.0)
    assert max(gaps(route)) <= 1.0 + 1e-9  # 1 m apart, the seam included
    drivable = [ln.centerline for ln in road.lanes if ln.id not in ("out", ":out", "back", "foot")]
    assert off_lines(route.waypoints, drivable) < 1e-6  # on the centre lines


def test_a_bike_rides_the_right_edge_of_the_ring() -> None:
    route = plan_route(ring_map(), "bike", -40.0, 0.0, 0.0, seed=1, min_loop_m=1000.0)
    assert route is not None and route.loop_from is not None
    # 0.8 m from the right edge of a 3.2 m lane: 0.8 m right of its centre line
    south = [p for p in route.waypoints if 10 < p[0] < 90 and p[1] < 50]  # eastbound: right, S
    west = [p for p in route.waypoints if 10 < p[1] < 90 and p[0] < 50]  # southbound: right, W
    assert south and all(abs(y - (-0.8)) < 1e-6 for _, y in south)
    assert west and all(abs(x - (-0.8)) < 1e-6 for x, _ in west)
    assert max(gaps(route)) <= 1.0 + 1e-9


def test_a_dead_end_street_is_driven_to_its_end_not_u_turned() -> None:
    # On `out` the only way on is a U-turn at its end: no loop, the route stops there.
    route = plan_route(ring_map(), "car", 120.0, 0.0, 0.0, seed=1)
    assert route is not None and route.loop_from is None
    assert route.lanes == ["out"] and route.waypoints[-1] == pytest.approx((160.0, 0.0))


def test_no_route_far_from_every_lane_or_against_the_traffic() -> None:
    road = ring_map()
    assert plan_route(road, "car", 50.0, 50.0, 0.0, seed=1) is None  # in the block, 50 m off
    assert plan_route(road, "car", 50.0, 0.0, math.pi, seed=1) is None  # facing the wrong way


@given(st.lists(st.tuples(st.integers(0, 9), st.integers(0, 9)), max_size=30))
def test_strongly_connected_components_are_the_mutually_reachable_sets(edges: list) -> None:
    nodes = {str(n) for edge in edges for n in edge} | {"lonely"}
    graph: dict[str, list[str]] = {n: [] for n in nodes}
    for a, b in edges:
        graph[str(a)].append(str(b))

    def reach(n: str) -> set[str]:
        seen, todo = {n}, [n]
        while todo:
            for m in graph[todo.pop()]:
                if m not in seen:
                    seen.add(m)
                    todo.append(m)
        return seen

    reaches = {n: reach(n) for n in nodes}
    expected = {frozenset(m for m in nodes if m in reaches[n] and n in reaches[m]) for n in nodes}
    found = strongly_connected(nodes, graph)
    assert {frozenset(c) for c in found} == expected and sum(map(len, found)) == len(nodes)


# ---------------------------------------------------------------- the town SUMO builds


@pytest.fixture(scope="module")
def town(net_cache: Path) -> tuple[MapReply, dict]:
    from carlaverse.traffic.mapdata import build_map_reply, read_net
    from carlaverse.traffic.netbuild import build_map
    from carlaverse.traffic.scenario import load_scenario
    from carlaverse.traffic.spawns import resolve_spawns

    scenario = load_scenario("town")
    net = read_net(build_map(scenario, net_cache).net)
    return build_map_reply(net, "town"), resolve_spawns(net, scenario.spec.egos)


@pytest.mark.parametrize(("kind", "lanes"), [("drive", "car"), ("bike", "bike")])
def test_every_town_spawn_gets_a_closed_route_on_its_lanes(town, kind: str, lanes: str) -> None:
    road, spawns = town
    ok = [ln for ln in road.lanes if ln.kind == "road" and len(ln.centerline) >= 2]
    for index, spawn in enumerate(spawns[kind]):
        route = plan_route(road, lanes, spawn.x, spawn.y, spawn.yaw, seed=index)
        assert route is not None and route.loop_from is not None, spawn
        start_gap = math.dist(route.waypoints[0], (spawn.x, spawn.y))  # a rider: 0.8 m right
        assert start_gap < (0.8 + 1e-3 if lanes == "bike" else 1e-3)
        assert route.loop_m >= 1500.0 and max(gaps(route)) <= 1.0 + 1e-9
        # a car on its lanes' centre lines; a rider 0.8 m inside their 3.2 m width (0.8 off)
        assert off_lines(route.waypoints[::7], [ln.centerline for ln in ok]) < (
            0.8 + 1e-3 if lanes == "bike" else 1e-3
        )
        # the loop never leaves the town: a street out of it ends at a dead end
        dead_ends = {ln.id for ln in ok if not ln.successors}
        assert not dead_ends & set(route.lanes), dead_ends & set(route.lanes)


def test_the_seed_chooses_the_turns(town) -> None:
    road, spawns = town
    spawn = spawns["drive"][0]
    routes = [plan_route(road, "car", spawn.x, spawn.y, spawn.yaw, seed=s) for s in (7, 7, 8)]
    assert routes[0] == routes[1]  # the same seed: the same route
    assert routes[0].lanes != routes[2].lanes  # another: other turns in the 3 x 3 grid
