"""The `sim` path driver on routes a node hands it: loops that never end, bends it slows for,
a look-ahead that shrinks with speed, and the hold while a route is on its way."""

from __future__ import annotations

import itertools
import math

import pytest

from carlaverse.config import ConfigError
from carlaverse.hal.input.speed_plan import corner_speeds
from tests.hal.helpers import ManualClock
from tests.hal.test_input import drive_bicycle, sim


def circle(radius: float, points: int, centre: tuple[float, float] = (0.0, 0.0)) -> list:
    """Counter-clockwise from the circle's south point, without repeating it at the end."""
    cx, cy = centre
    return [(cx + radius * math.sin(2 * math.pi * k / points),
             cy - radius * math.cos(2 * math.pi * k / points)) for k in range(points)]  # fmt: skip


def test_a_loop_is_lapped_without_stopping() -> None:
    # A 20 m circle at 6 m/s is a lap every 2π·20/6 = 20.9 s: 50 s is over two laps. An open
    # path would brake to a stop at its last waypoint; a loop goes on at `loop_from`.
    ring = circle(20.0, 126)  # ~1 m apart
    clock = ManualClock()
    path = {"waypoints": ring, "target_speed_mps": 6.0, "loop_from": 0}
    device = sim({"mode": "path", "path": path}, clock)
    trace = drive_bicycle(device, clock, 50.0, start=(0.0, -20.0, 0.0, 0.0))
    turned = sum(math.remainder(b[2] - a[2], 2 * math.pi) for a, b in itertools.pairwise(trace))
    assert turned > 2 * 2 * math.pi  # over two full turns of heading, counter-clockwise
    assert abs(trace[-1][3] - 6.0) < 0.5  # still at its speed
    radii = [math.hypot(x, y) for x, y, _, _ in trace[1500:]]  # once settled
    assert max(abs(r - 20.0) for r in radii) < 0.3  # on the circle: pure pursuit on an arc


def test_a_loop_from_past_the_waypoints_is_a_config_error() -> None:
    path = {"waypoints": [(0, 0), (10, 0)], "loop_from": 2}
    with pytest.raises(ConfigError, match=r"path\.loop_from 2 is past the last of the 2"):
        sim({"mode": "path", "path": path}, ManualClock())


def test_corner_speeds_worked_by_hand() -> None:
    # 60 m straight, then a quarter circle of R = 20 m (~1 m steps). At a_lat = 2 m/s² the
    # arc allows √(2·20) = 6.32 m/s. The curvature is measured over 1.5 m each side of a point
    # and a point takes the tightest within 3 m, so the limit holds from between 3 m before
    # the arc (x = -3) and its start (x = 0). Upstream of there (x0) the speed is the braking
    # ramp at 2.5 m/s², √(6.32² + 2·2.5·(x0 − x)), up to the target of 10 m/s.
    straight = [(float(x), 0.0) for x in range(-60, 0)]
    arc = [(20 * math.sin(a / 31 * math.pi / 2), 20 - 20 * math.cos(a / 31 * math.pi / 2))
           for a in range(32)]  # fmt: skip
    speeds = corner_speeds(straight + arc, 10.0, 2.0, 2.5)
    at = {round(p[0]): v for p, v in zip(straight + arc, speeds, strict=True) if p[1] == 0}
    limit = math.sqrt(2.0 * 20.0)
    x0 = min(x for x, v in at.items() if v < limit + 0.01)
    assert -3 <= x0 <= 0
    assert at[-40] == 10.0  # long before: the target
    for x in range(x0 - 12, x0):  # on the ramp (12 m long: (10² − 6.32²)/(2·2.5))
        ramp = math.sqrt(limit**2 + 2 * 2.5 * (x0 - x))
        assert at[x] == pytest.approx(min(10.0, ramp), abs=0.01)
    on_arc = speeds[len(straight) : len(straight) + 28]
    assert all(abs(v - limit) < 0.05 for v in on_arc)  # κ = 1/20 all along the arc


def test_a_loop_brakes_at_its_end_for_the_bend_at_its_start() -> None:
    # The loop's first points are a tight bend: its last points, which lead into them,
    # must already be slow. Straight from (0, 0) west, then a 5 m bend back into (0, 0).
    ring = [(5 * math.sin(a / 16 * math.pi), 5 - 5 * math.cos(a / 16 * math.pi))
            for a in range(16)]  # fmt: skip
    ring += [(float(x), 10.0) for x in range(-1, -40, -1)]
    ring += [(-40 - 5 * math.sin(a / 16 * math.pi), 5 + 5 * math.cos(a / 16 * math.pi))
             for a in range(16)]  # fmt: skip
    ring += [(float(x), 0.0) for x in range(-40, 0)]
    open_end = corner_speeds(ring, 12.0, 2.0, 2.5)
    looped = corner_speeds(ring, 12.0, 2.0, 2.5, loop_from=0)
    bend = math.sqrt(2.0 * 5.0)  # 3.16 m/s through the R = 5 m bends
    assert open_end[-1] > 8.0  # nothing ahead of an open path's end
    assert looped[-1] < bend + 1.0  # 1 m before the bend it is all but there


def test_a_bend_is_taken_at_the_lateral_acceleration_asked_for() -> None:
    # 60 m straight then a quarter circle of R = 15 m; a_lat = 2 m/s² allows √30 = 5.48 m/s.
    # Braking down the planned 2.5 m/s² ramp, the proportional pedal (0.5 per m/s of error)
    # against the test bicycle's 6 m/s² brake runs 2.5/(0.5·6) = 0.83 m/s above its goal,
    # an error that fades with a time constant of 1/(0.5·6) = 0.33 s once the goal is flat.
    radius = 15.0
    arc = [(radius * math.sin(a / 24 * math.pi / 2), radius * (1 - math.cos(a / 24 * math.pi / 2)))
           for a in range(25)]  # fmt: skip
    waypoints = [(float(x), 0.0) for x in range(-60, 0)] + arc + [(15.0, y) for y in range(16, 60)]
    clock = ManualClock()
    path = {"waypoints": waypoints, "target_speed_mps": 10.0, "corner_accel_mps2": 2.0}
    device = sim({"mode": "path", "path": path}, clock)
    trace = drive_bicycle(device, clock, 25.0, start=(-60.0, 0.0, 0.0, 0.0))
    assert max(v for *_, v in trace) > 9.5  # the straight at its speed
    limit = math.sqrt(2.0 * radius)
    on_arc = [v for x, y, _, v in trace if 0.0 < x < 13.0 and 0.0 < y < 13.0]
    assert on_arc and max(on_arc) < limit + 0.83
    assert abs(sorted(on_arc)[len(on_arc) // 2] - limit) < 0.2  # most of the arc at the limit


def test_a_slow_turn_looks_nearer_and_cuts_its_corner_less() -> None:
    # A right-angle turn of R = 6 m at 4 m/s. Pure pursuit starts turning when its look-ahead
    # point reaches the bend and so cuts the corner, by an amount that grows as l_d² (for
    # l_d small against R: l_d²/(2R)). Shrunk with the speed, the look-ahead is 0.8 s · 4 m/s
    # = 3.2 m instead of 6 m: (3.2/6)² = 0.28 of the cut.
    radius = 6.0
    arc = [(radius * math.sin(a / 12 * math.pi / 2), radius * (1 - math.cos(a / 12 * math.pi / 2)))
           for a in range(13)]  # fmt: skip
    waypoints = [(float(x), 0.0) for x in range(-40, 0)] + arc + [(6.0, y) for y in range(7, 50)]

    def worst_cut(extra: dict) -> float:
        clock = ManualClock()
        path = {"waypoints": waypoints, "target_speed_mps": 4.0, **extra}
        trace = drive_bicycle(sim({"mode": "path", "path": path}, clock), clock, 20.0,
                              start=(-40.0, 0.0, 0.0, 4.0))  # fmt: skip
        # inside the turn: nearer its centre (0, 6) than the arc
        return max(radius - math.hypot(x, y - radius) for x, y, _, _ in trace if x > -3 and y < 9)

    fixed, shrunk = worst_cut({}), worst_cut({"lookahead_time_s": 0.8})
    assert fixed > 0.3  # the corner is cut
    assert shrunk < (3.2 / 6.0) ** 2 * fixed + 0.05


def test_hold_brakes_and_follow_hands_over_a_route() -> None:
    clock = ManualClock()
    device = sim({"mode": "path", "path": {"waypoints": [(0, 0), (100, 0)]}}, clock)
    device.observe(0.0, 0.0, 0.0, 0.0)
    device.hold()
    assert device.poll().axes == {"steer": 0.0, "throttle": 0.0, "brake": 1.0}
    device.follow([(0.0, float(y)) for y in range(100)])  # due north: left, from facing east
    axes = device.poll().axes
    assert axes["steer"] > 0.5 and axes["throttle"] > 0 and axes["brake"] == 0
    device.follow(None)  # the configured path again: straight ahead
    axes = device.poll().axes
    assert axes["steer"] == 0.0 and axes["throttle"] > 0
