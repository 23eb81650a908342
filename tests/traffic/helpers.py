"""Plumbing for traffic and domain tests: scripted egos, scenario files, lane geometry."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from carlaverse.authority.domain import EgoTrack
from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.authority.traffic_domain import TrafficDomain, load_domain
from carlaverse.config import shipped_dir
from carlaverse.messages import EgoInfo, Extent, MapReply, NpcBatch, Pose
from tests.support import wait_until

MAPS = shipped_dir("carlaverse.scenarios") / "maps"
TICK_S = 0.02  # [s] the shipped scenarios tick at 50 Hz
T0 = 1000.0  # [s] session time of the first tick: the domain must not assume 0

CROSSING_MAP = f"""
map:
  plain:
    nodes: {MAPS / "crossing.nod.xml"}
    edges: {MAPS / "crossing.edg.xml"}
    connections: {MAPS / "crossing.con.xml"}
"""
# One scripted car and no other traffic: it leaves the west end of WZ at 10 m/s and reaches
# the zebra after ~10 s.
FOLLOWER = """
traffic:
  vehicles: {count: 0}
  pedestrians: {count: 0}
  scripted_vehicles:
    - {id: follower, edges: [WZ, ZC, CE], depart_speed_mps: 10}
"""


CAR = Extent(4.5, 1.8, 1.5)  # [m]
# On the crossing map: where the northbound bike lane SC_1 crosses the eastbound car lane ZC_2
# (through the junction on :C_22_0), the conflict point of the trigger tests.
CROSSING_CONFLICT = (164.05, 118.35)  # [m]


@pytest.fixture(scope="session")
def net_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One network cache for the whole run: each map is built by netconvert once."""
    return tmp_path_factory.mktemp("carlaverse-cache")


def ego_track(
    node_id: str,
    actor_kind: str = "car",
    kind: str = "drive",
    extent: Extent = CAR,
    mass_kg: float = 1500.0,
) -> EgoTrack:
    info = EgoInfo(node_id, kind, actor_kind, extent, mass_kg)
    return EgoTrack(info, instance="test", joined_t=T0)


def pose(t: float, x: float, y: float, yaw: float = 0.0, speed: float = 0.0) -> Pose:
    """A pose sample at t moving at `speed` [m/s] along its heading."""
    return Pose(0, t, x, y, yaw=yaw, vx=speed * math.cos(yaw), vy=speed * math.sin(yaw))


def write_scenario(tmp_path: Path, body: str, name: str = "test") -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"name: {name}\n{body}", encoding="utf-8")
    return path


@contextmanager
def domain_of(
    scenario: str | Path, cache: Path, seed: int | None = None, sumo_process: bool = False
) -> Iterator[TrafficDomain]:
    """The scenario's domain; SUMO in this process unless asked, so tests can look into it
    with libsumo and the ticks see each step's NPCs at once (no race with another process)."""
    domain = load_domain(scenario, seed, cache_dir=cache, sumo_process=sumo_process)
    try:
        yield domain
    finally:
        domain.close()


def run(
    domain: TrafficDomain,
    out: MemoryOutbox,
    start_t: float,
    seconds: float,
    egos: Callable[[float], dict[str, EgoTrack]] = lambda t: {},
    every: Callable[[float], None] = lambda t: None,
) -> float:
    """Tick the domain at 50 Hz for `seconds`; returns the session time after the last tick."""
    t = start_t
    for k in range(round(seconds / TICK_S)):
        t = start_t + k * TICK_S
        domain.tick(t, egos(t), out)
        every(t)
    return t + TICK_S


def wait_for_step(domain: TrafficDomain, timeout_s: float = 30.0) -> None:
    """Until SUMO's process has sent the step in flight back, so no tick defers a step: the
    run's traffic is then the in-process run's, tick for tick."""
    wait_until(lambda: not domain.engine.stepping, timeout_s, "SUMO's process", poll=0.0005)


def lane_point(reply: MapReply, lane_id: str, pos_m: float) -> tuple[float, float, float]:
    """(x, y, heading) at `pos_m` along a lane's centre line."""
    line = next(lane.centerline for lane in reply.lanes if lane.id == lane_id)
    for (x0, y0), (x1, y1) in itertools.pairwise(line):
        seg = math.hypot(x1 - x0, y1 - y0)
        if pos_m <= seg or (x1, y1) == line[-1]:
            f = min(pos_m / seg, 1.0) if seg else 0.0
            return (x0 + f * (x1 - x0), y0 + f * (y1 - y0), math.atan2(y1 - y0, x1 - x0))
        pos_m -= seg
    raise AssertionError(f"lane {lane_id} has no geometry")


def npc_row(batch: NpcBatch, npc_id: str) -> np.void:
    return batch.array()[batch.ids.index(npc_id)]
