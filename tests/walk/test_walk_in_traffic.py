"""Real SUMO: an NPC car stops for the walk node's walker on the zebra, then drives on; the
walker is held on walkable ground.

The walker is the walk node's own control loop (`WalkControl` at 90 Hz with the simulated
standing headset and its scripted thumbstick, lanes snapping on the map the authority serves),
advanced to each 50 Hz authority tick; its pose goes into the ego track as the authority
would get it from the fabric. The authority carries a `pedestrian` ego into SUMO as a
walking person (`carlaverse/traffic/sumo_egos.py`), which SUMO's crossing logic sees.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from carlaverse_nodes.walk.config import PEDESTRIAN, WalkNodeConfig
from carlaverse_nodes.walk.walk_control import WalkControl
from carlaverse_nodes.walk.walkable import LaneSettings, Walkable

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.hal import XrConfig, open_xr
from carlaverse.messages import ContactStarted, MapReply, Pose
from tests.traffic.helpers import (
    CROSSING_MAP,
    FOLLOWER,
    T0,
    domain_of,
    ego_track,
    lane_point,
    net_cache,
    npc_row,
    run,
    write_scenario,
)

pytest.importorskip("libsumo")
__all__ = ["net_cache"]

LOOP_DT = 1.0 / 90.0  # [s] the walk loop's 90 Hz


class WalkerOnTheLoop:
    """The walk control loop advanced to each authority tick, on a manual clock."""

    def __init__(self, reply: MapReply, x: float, y: float, yaw: float, script: list) -> None:
        self.t = 0.0  # [s] since the headset opened
        options = {"posture": "standing", "yaw_amplitude_rad": 0.0, "pitch_amplitude_rad": 0.0,
                   "sway_m": 0.0, "script": script}  # fmt: skip
        config = WalkNodeConfig(xr=XrConfig(backend="sim", options=options),
                                lanes=LaneSettings(snap=True))  # fmt: skip
        self.control = WalkControl(config, open_xr(config.xr, clock=lambda: self.t))
        self.control.walkable = Walkable.from_map(reply, config.lanes)
        self.control.place(x, y, yaw)
        self.track = ego_track("walker", actor_kind="pedestrian", kind="walk",
                               extent=PEDESTRIAN, mass_kg=75.0)  # fmt: skip
        self.pose = Pose(0, T0, x, y, yaw=yaw)

    def egos(self, t: float) -> dict:
        while self.t < t - T0 - 1e-9:
            self.t += LOOP_DT
            out = self.control.tick(LOOP_DT)
            h = out.head
            self.pose = Pose(0, T0 + self.t, h.x, h.y, yaw=h.yaw, vx=out.vx, vy=out.vy)
        self.track.last_pose = self.pose
        return {"walker": self.track}


def zebra(reply: MapReply) -> tuple[float, float, float]:
    """x of the zebra's centre line and its south and north ends [m]."""
    line = next(lane.centerline for lane in reply.lanes if lane.id == ":Z_c0_0")
    (x, y0), (_, y1) = line[0], line[-1]
    return x, min(y0, y1), max(y0, y1)


def test_npc_car_stops_for_the_walker_crossing_at_the_zebra(tmp_path: Path, net_cache) -> None:
    scenario = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    with domain_of(scenario, net_cache) as domain:
        reply = domain.map_reply()
        zebra_x, south, north = zebra(reply)
        _, lane_y, _ = lane_point(reply, "WZ_2", 50.0)  # the eastbound car lane's centre
        # At the zebra's south end, facing north; the script walks into the car lane and
        # stands there, then walks on to the far side.
        script = [{"t": 0.0, "axes": {"move_y": 0.0}}, {"t": 0.5, "axes": {"move_y": 0.0}},
                  {"t": 0.51, "axes": {"move_y": 1.0}}, {"t": 3.7, "axes": {"move_y": 1.0}},
                  {"t": 3.71, "axes": {"move_y": 0.0}}, {"t": 16.0, "axes": {"move_y": 0.0}},
                  {"t": 16.01, "axes": {"move_y": 1.0}}]  # fmt: skip
        walker = WalkerOnTheLoop(reply, zebra_x, south - 1.0, math.pi / 2, script)
        out = MemoryOutbox()
        t = run(domain, out, T0, 6.0, egos=walker.egos)
        assert abs(walker.pose.y - lane_y) < 1.0, "the walker stands in the car lane"
        assert (
            abs(walker.pose.x - zebra_x) < 0.1 and math.hypot(walker.pose.vx, walker.pose.vy) == 0
        )
        fronts = []  # the follower's bumper while the walker stands in its lane
        t = run(domain, out, t, 10.0, egos=walker.egos,
                every=lambda _: fronts.append(_front(out)))  # fmt: skip
        follower = npc_row(out.npcs[-1], "follower")
        assert math.hypot(follower["vx"], follower["vy"]) < 0.05  # [m/s] it waits
        front = follower["x"] + follower["length"] / 2
        assert zebra_x - 8.0 < front < zebra_x - 2.0  # [m] at the zebra, not on it
        assert max(f for f in fronts if f is not None) < zebra_x - 2.0  # never on the zebra
        assert walker.control.snaps == 0  # the walking area and the zebra are walkable
        # The walker walks on across: the car drives over the zebra once they are clear.
        run(domain, out, t, 12.0, egos=walker.egos)
        assert walker.pose.y > north + 1.0  # on the far side's walking area
        follower = npc_row(out.npcs[-1], "follower")
        assert follower["x"] - follower["length"] / 2 > zebra_x
        assert not [e for e in out.events if isinstance(e, ContactStarted)]


def _front(out: MemoryOutbox) -> float | None:
    batch = out.npcs[-1] if out.npcs else None
    if batch is None or "follower" not in batch.ids:
        return None
    row = npc_row(batch, "follower")
    return float(row["x"] + row["length"] / 2)


def test_snapping_keeps_the_walker_on_the_sidewalk(tmp_path: Path, net_cache) -> None:
    scenario = write_scenario(tmp_path, CROSSING_MAP + FOLLOWER)
    with domain_of(scenario, net_cache) as domain:
        reply = domain.map_reply()
    x, y, _ = lane_point(reply, "WZ_0", 50.0)  # mid-block: no crossing here
    walker = WalkerOnTheLoop(reply, x, y, math.pi / 2, [{"t": 0.0, "axes": {"move_y": 1.0}}])
    walker.egos(T0 + 5.0)  # 5 s walking north, into the road
    # WZ_0 is 2.5 m wide: the walker stops at its north edge plus the 0.25 m margin.
    assert walker.pose.y == pytest.approx(y + 1.25 + 0.25, abs=0.01)
    assert walker.pose.x == pytest.approx(x, abs=1e-6)
    assert walker.control.snaps > 0
    assert math.hypot(walker.pose.vx, walker.pose.vy) < 0.05  # pressed against the edge
