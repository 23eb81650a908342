"""NPCs see the humans: they queue behind a driver or a cyclist and yield to a walker.

Real SUMO, mostly on the shipped crossing map (W - Z(ebra) - C(entre), lanes _0 sidewalk,
_1 bike, _2 car). No random traffic: one scripted NPC meets one scripted ego.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.messages import ContactStarted, Extent
from carlaverse.traffic.sumo_tools import import_libsumo
from tests.traffic.helpers import (
    CROSSING_MAP,
    FOLLOWER,
    T0,
    domain_of,
    ego_track,
    lane_point,
    npc_row,
    pose,
    run,
    wait_for_step,
    write_scenario,
)


@pytest.mark.parametrize("sumo_process", [False, True], ids=["in_process", "own_process"])
def test_npc_queues_behind_a_stopped_human_driver(
    tmp_path: Path, net_cache: Path, sumo_process: bool
) -> None:
    """Also through SUMO's own process, the default, where the egos cross a pipe as columns."""
    scenario = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    with domain_of(scenario, net_cache, sumo_process=sumo_process) as domain:
        x, y, yaw = lane_point(domain.map_reply(), "WZ_2", 60.0)  # ego centre, 60 m down WZ
        track = ego_track("driver")
        track.last_pose = pose(T0, x, y, yaw)
        out = MemoryOutbox()
        run(domain, out, T0, 25.0, egos=lambda t: {"driver": track},
            every=lambda t: wait_for_step(domain))  # fmt: skip
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) < 0.05  # [m/s] it has stopped
        gap = (x - 4.5 / 2) - (follower["x"] + follower["length"] / 2)  # [m] bumper to bumper
        assert 0.5 < gap < 5.0, gap  # queued at SUMO's minimum gap (2.5 m), not touching
        assert not [e for e in out.events if isinstance(e, ContactStarted)]


def test_npc_yields_to_a_human_walker_on_the_zebra(tmp_path: Path, net_cache: Path) -> None:
    scenario = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    with domain_of(scenario, net_cache) as domain:
        reply = domain.map_reply()
        zebra_x = lane_point(reply, ":Z_c0_0", 0.0)[0]  # the zebra runs north-south
        _, car_lane_y, _ = lane_point(reply, "WZ_2", 100.0)
        walker = ego_track("walker", actor_kind="pedestrian", kind="walk",
                           extent=Extent(0.3, 0.5, 1.75), mass_kg=75.0)  # fmt: skip
        walker.last_pose = pose(T0, zebra_x, car_lane_y, math.pi / 2)
        out = MemoryOutbox()
        t = run(domain, out, T0, 20.0, egos=lambda t: {"walker": walker})
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) < 0.05  # [m/s] waiting
        front = follower["x"] + follower["length"] / 2
        assert zebra_x - 8.0 < front < zebra_x - 2.0  # [m] at the stop line, not on the zebra
        assert not [e for e in out.events if isinstance(e, ContactStarted)]
        # The walker leaves the zebra (despawns): the NPC drives on across it.
        run(domain, out, t, 8.0)
        follower = npc_row(out.npcs[-1], "follower")
        assert follower["x"] - follower["length"] / 2 > zebra_x


def test_a_despawned_ego_leaves_sumo(tmp_path: Path, net_cache: Path) -> None:
    scenario = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    with domain_of(scenario, net_cache) as domain:
        x, y, yaw = lane_point(domain.map_reply(), "WZ_2", 30.0)
        track = ego_track("driver")
        track.last_pose = pose(T0, x, y, yaw)
        out = MemoryOutbox()
        t = run(domain, out, T0, 1.0, egos=lambda t: {"driver": track})
        ls = import_libsumo()
        assert "@driver" in ls.vehicle.getIDList()
        assert "driver" not in out.npcs[-1].ids  # egos are not NPCs
        domain.ego_left("driver")
        run(domain, out, t, 0.2)
        assert "@driver" not in ls.vehicle.getIDList()


CYCLIST_TOWN = """
map: {generate: {kind: grid, grid: {junctions: 3, length_m: 120, attach_length_m: 60}}}
traffic:
  vehicles: {count: 0}
  pedestrians: {count: 0}
  scripted_vehicles:
    - {id: follower, edges: [A1B1, B1C1], depart_speed_mps: 10}
"""


def test_npc_queues_behind_a_human_cyclist(tmp_path: Path, net_cache: Path) -> None:
    """In a town without bike lanes the cyclist rides in the car lane: the NPC follows."""
    scenario = write_scenario(tmp_path, CYCLIST_TOWN, "cyclist-town")
    with domain_of(scenario, net_cache) as domain:
        x0, y, yaw = lane_point(domain.map_reply(), "A1B1_1", 30.0)
        rider = ego_track("rider", actor_kind="bicycle", kind="bike",
                          extent=Extent(1.8, 0.65, 1.7), mass_kg=90.0)  # fmt: skip

        def egos(t: float) -> dict:
            s = 4.0 * (t - T0)  # [m] riding east at 4 m/s
            rider.last_pose = pose(t, x0 + s * math.cos(yaw), y + s * math.sin(yaw), yaw, 4.0)
            return {"rider": rider}

        out = MemoryOutbox()
        run(domain, out, T0, 12.0, egos=egos)  # the rider ends 78 m down the block
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) == pytest.approx(4.0, abs=0.5)
        gap = rider.last_pose.x - 0.9 - (follower["x"] + follower["length"] / 2)  # [m]
        assert 1.0 < gap < 15.0, gap
        assert not [e for e in out.events if isinstance(e, ContactStarted)]
