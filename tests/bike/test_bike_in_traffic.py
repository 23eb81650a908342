"""Real SUMO: an NPC queues behind the bike node's own physics (its published poses).

The rider is the bike node's `BikeLoop` at 200 Hz on the wheel speed of a simulated wheel-
speed sensor; every 50 Hz authority tick gets the loop's pose sample (absolute velocity, lean
as roll), as the authority would from the fabric.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, resolve_table

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.hal import open_speed_sensor
from carlaverse.messages import ContactStarted, Extent
from tests.traffic.helpers import (
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
