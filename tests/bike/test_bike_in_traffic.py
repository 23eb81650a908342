"""Real SUMO: NPCs queue behind the bike node's own physics and yield to it at a junction.

The rider is the bike node's `BikeLoop` at 200 Hz on the wheel speed of a simulated wheel-
speed sensor; every 50 Hz authority tick gets the loop's pose sample (absolute velocity, lean
as roll), as the authority would from the fabric.

What SUMO's junction model gives a carried bike: the authority moves it with `moveToXY`, so
its route is only the edge it is on and it never announces its approach to a junction's
links. An NPC therefore yields to the bike once the bike is inside the junction (on the
junction's internal lane that crosses the NPC's path), not to a bike still riding up to it.
The yield test sets up the first case: the rider is in the junction before the car arrives.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, resolve_table

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.authority.traffic_domain import TrafficDomain
from carlaverse.hal import open_speed_sensor
from carlaverse.messages import ContactStarted, Extent
from tests.traffic.helpers import (
    CROSSING_MAP,
    T0,
    TICK_S,
    domain_of,
    ego_track,
    lane_point,
    net_cache,
    npc_row,
    run,
    write_scenario,
)
from tests.traffic.test_humans_in_traffic import CYCLIST_TOWN  # its grid, one NPC

pytest.importorskip("libsumo")
__all__ = ["net_cache"]

LOOP_DT = 0.005  # [s] the bike loop's 200 Hz
HALF_WIDTH_M = 0.9  # [m] half the NPC car's width (SUMO's default passenger car, 1.8 m)


class RiderOnTheLoop:
    """The bike loop advanced to each authority tick; its pose goes into the ego track."""

    def __init__(self, x: float, y: float, yaw: float, speed_profile: list[dict]) -> None:
        config = BikeNodeConfig()
        self.loop = BikeLoop(config, resolve_table(config))
        self.loop.place(x, y, yaw)
        self.t = 0.0
        self.sensor = open_speed_sensor(
            {"backend": "sim", "options": {"profile": speed_profile}}, clock=lambda: self.t
        )
        b = config.bicycle
        self.track = ego_track("rider", actor_kind="bicycle", kind="bike",
                               extent=Extent(b.length_m, b.width_m, b.height_m),
                               mass_kg=b.mass_kg)  # fmt: skip

    def egos(self, t: float) -> dict:
        while self.t < t - T0 - 1e-9:
            self.t += LOOP_DT
            out = self.loop.step(LOOP_DT, self.sensor.read().speed_mps, 0.0, 0.0, now=T0 + self.t)
            self.track.last_pose = out.pose()
        return {"rider": self.track}


def test_npc_queues_behind_the_bike_riding_at_4_mps(tmp_path: Path, net_cache: Path) -> None:
    scenario = write_scenario(tmp_path, CYCLIST_TOWN, "bike-town")
    with domain_of(scenario, net_cache) as domain:
        x0, y, yaw = lane_point(domain.map_reply(), "A1B1_1", 30.0)
        rider = RiderOnTheLoop(x0, y, yaw, [{"t": 0, "speed_mps": 4.0}])
        out = MemoryOutbox()
        run(domain, out, T0 + TICK_S, 12.0, egos=rider.egos)
        pose = rider.track.last_pose
        assert pose is not None and math.hypot(pose.vx, pose.vy) == pytest.approx(4.0)
        assert pose.x - x0 == pytest.approx(4.0 * 12.0, abs=0.2)  # the loop's own physics
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) == pytest.approx(4.0, abs=0.5)
        gap = pose.x - 0.9 - (follower["x"] + follower["length"] / 2)  # [m] to the rear wheel
        assert 1.0 < gap < 15.0, gap
        assert not [e for e in out.events if isinstance(e, ContactStarted)]


def test_npc_stops_behind_the_bike_when_the_rider_stops(tmp_path: Path, net_cache: Path) -> None:
    scenario = write_scenario(tmp_path, CYCLIST_TOWN, "bike-town")
    with domain_of(scenario, net_cache) as domain:
        x0, y, yaw = lane_point(domain.map_reply(), "A1B1_1", 30.0)
        # 4 m/s for 6 s, then the rider brakes to a standstill within 2 s and waits
        profile = [{"t": 0, "speed_mps": 4.0}, {"t": 6, "speed_mps": 4.0},
                   {"t": 8, "speed_mps": 0.0}]  # fmt: skip
        rider = RiderOnTheLoop(x0, y, yaw, profile)
        out = MemoryOutbox()
        run(domain, out, T0 + TICK_S, 16.0, egos=rider.egos)
        pose = rider.track.last_pose
        assert pose is not None and pose.vx == 0.0
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) < 0.05  # [m/s] it waits
        gap = pose.x - 0.9 - (follower["x"] + follower["length"] / 2)
        assert 0.5 < gap < 5.0, gap  # at SUMO's minimum gap, not touching
        assert not [e for e in out.events if isinstance(e, ContactStarted)]


RIGHT_TURNER = (
    CROSSING_MAP
    + """
traffic:
  vehicles: {count: 0}
  pedestrians: {count: 0}
  scripted_vehicles:
    - {id: turner, edges: [SC, CE], depart_speed_mps: 10}  # north, then right (east) at C
"""
)


def ride_the_turn(
    domain: TrafficDomain, rider: RiderOnTheLoop | None
) -> tuple[list[tuple], MemoryOutbox]:
    """16 s of the junction; per tick (t, NPC x, y, speed, rider's y or None)."""
    out, rows = MemoryOutbox(), []

    def log(t: float) -> None:
        if "turner" in out.npcs[-1].ids:
            r = npc_row(out.npcs[-1], "turner")
            pose = rider.track.last_pose if rider else None
            rows.append((t, r["x"], r["y"], math.hypot(r["vx"], r["vy"]), pose and pose.y))

    run(domain, out, T0 + TICK_S, 16.0, egos=rider.egos if rider else lambda t: {}, every=log)
    return rows, out


def test_npc_turning_right_waits_for_the_bike_crossing_the_junction(
    tmp_path: Path, net_cache: Path
) -> None:
    """The right hook, averted: the car turning right across the bike lane lets the rider by.

    The shipped crossing map's light C is green for north-south from the start. The NPC drives
    north in the car lane SC_2 at up to 13 m/s and turns right into CE; the rider goes straight
    north in the bike lane SC_1 at 3 m/s (11 km/h), 22.5 m before the junction at the start, so
    it is inside the junction (1.5 s after entering it, ~1 m short of the car's path) when the
    car reaches it. SUMO gives the straight bike lane priority over the right turn ('G' over
    'g'), so the car must wait. The start was chosen in the middle of the window where this
    set-up yields without contact: starting 2 m further back the car hits the rider, 2.5 m
    further ahead it only slows a little (scanned), i.e. ±0.7 s of the rider's timing. Those
    later arrivals of the rider are the approach case the module docstring explains.
    """
    scenario = write_scenario(tmp_path, RIGHT_TURNER, "right-hook")
    with domain_of(scenario, net_cache) as domain:
        free, _ = ride_the_turn(domain, None)
    with domain_of(scenario, net_cache) as domain:
        reply = domain.map_reply()
        bike_lane = next(lane.centerline for lane in reply.lanes if lane.id == "SC_1")
        to_junction_m = sum(itertools.starmap(math.dist, itertools.pairwise(bike_lane)))
        x0, y0, yaw = lane_point(reply, "SC_1", to_junction_m - 22.5)
        rider = RiderOnTheLoop(x0, y0, yaw, [{"t": 0, "speed_mps": 3.0}])
        rows, out = ride_the_turn(domain, rider)
    turning = lambda rs: [r for r in rs if r[2] > y0 + 10 and r[1] < x0 + 2]  # noqa: E731
    free_min = min(r[3] for r in turning(free))
    assert free_min > 4.0  # [m/s] alone, it takes the turn without stopping (SUMO: ~5.6)
    assert min(r[3] for r in turning(rows)) < 0.5 * free_min  # it brakes for the rider
    # It reaches the bike lane's centre line only once the rider's rear wheel is past the
    # car's whole width there: the rider crossed its path first.
    crossing = next((r for r in rows if r[1] >= x0), None)
    assert crossing is not None, "the NPC never crossed the bike lane"
    t, _, y, _, rider_y = crossing
    rear_y = rider_y - rider.loop.config.bicycle.length_m / 2  # [m] riding north
    assert rear_y > y + HALF_WIDTH_M, (t, y, rider_y)
    assert rows[-1][1] > x0 + 10.0  # and then completes its turn into CE
    assert not [e for e in out.events if isinstance(e, ContactStarted)]
