"""Collisions through the whole domain: scripted egos against a stopped SUMO NPC and each other.

The egos' pose samples are 10 ms old at each tick, so the domain's dead reckoning is part of
what is tested. Expected impulses are J = (1+e)·v/(1/m₁+1/m₂) along the lane (head-on, so the
normal is the lane direction): the tolerance of 5 % covers the NPC's float32 pose.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from carlaverse.authority.domain import EgoTrack
from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.messages import ContactEnded, ContactStarted
from tests.traffic.helpers import (
    CROSSING_MAP,
    T0,
    domain_of,
    ego_track,
    lane_point,
    net_cache,
    npc_row,
    pose,
    run,
    write_scenario,
)

PARKED = """
traffic:
  vehicles: {count: 0}
  pedestrians: {count: 0}
  scripted_vehicles:
    - {id: parked, edges: [ZC], depart_pos_m: 20, stop: {edge: ZC, pos_m: 25, duration_s: 1000}}
collisions:
  npc_hit_remove_after_s: 2.0
"""
__all__ = ["net_cache"]  # a fixture, imported for pytest
SAMPLE_AGE_S = 0.01  # [s] how old each pose sample is when the tick runs
EGO_MASS, CAR_MASS, E = 1200.0, 1500.0, 0.2  # [kg], [kg], restitution of cars (scenario default)


def scripted(
    node_id: str, start: tuple[float, float, float], speed: float, t_go: float
) -> tuple[EgoTrack, Callable[[float], None]]:
    """An ego that waits at `start` until t_go, then drives on at `speed` along its heading."""
    track = ego_track(node_id, mass_kg=EGO_MASS)

    def at(t: float) -> None:
        x, y, yaw = start
        s = max(0.0, t - t_go) * speed
        v = speed if t >= t_go else 0.0
        track.last_pose = pose(t, x + s * math.cos(yaw), y + s * math.sin(yaw), yaw, v)

    return track, at


def test_ego_driven_into_a_stopped_npc(tmp_path: Path, net_cache: Path) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + PARKED), net_cache) as domain:
        out = MemoryOutbox()
        t = run(domain, out, T0, 4.0)  # the NPC drives 5 m and stops
        parked = npc_row(out.npcs[-1], "parked")
        assert math.hypot(parked["vx"], parked["vy"]) < 1e-3
        x, y, yaw = lane_point(domain.map_reply(), "ZC_2", 2.0)
        track, move = scripted("driver", (x, y, yaw), 5.0, t)

        def egos(now: float) -> dict:
            move(now - SAMPLE_AGE_S)
            return {"driver": track}

        t = run(domain, out, t, 4.0, egos=egos)  # 20 m at 5 m/s: it hits the NPC at ~15 m
        impulses = [imp for node, imp in out.impulses if node == "driver"]
        assert len(impulses) == 1  # one impulse, although the boxes overlap for a second
        imp = impulses[0]
        expected = (1 + E) * 5.0 / (1 / EGO_MASS + 1 / CAR_MASS)  # [N·s]
        assert np.linalg.norm(imp.impulse) == pytest.approx(expected, rel=0.05)
        heading = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        assert np.dot(imp.impulse, heading) / np.linalg.norm(imp.impulse) < -0.999  # pushed back
        assert imp.other_id == "parked" and imp.other_kind == "car"
        assert imp.relative_speed_mps == pytest.approx(5.0, rel=0.05)
        started = [e for e in out.events if isinstance(e, ContactStarted)]
        assert len(started) == 1 and not [e for e in out.events if isinstance(e, ContactEnded)]
        # The driver backs off to 1 m behind: the contact end is announced at once.
        track.last_pose = pose(t, float(parked["x"] - parked["length"] / 2) - 1.0 - 2.25, y, yaw)
        t = run(domain, out, t, 0.1, egos=lambda now: {"driver": track})
        ended = [e for e in out.events if isinstance(e, ContactEnded)]
        assert len(ended) == 1 and ended[0].contact_id == started[0].contact_id
        assert "parked" in out.npcs[-1].ids
        assert np.hypot(*[npc_row(out.npcs[-1], "parked")[k] for k in ("vx", "vy")]) < 1e-3
        run(domain, out, t, 2.0, egos=lambda now: {"driver": track})
        assert "parked" not in out.npcs[-1].ids  # hit: stopped, then removed after 2 s


def test_ego_stopping_five_centimetres_short_gets_no_impulse(
    tmp_path: Path, net_cache: Path
) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + PARKED), net_cache) as domain:
        out = MemoryOutbox()
        t = run(domain, out, T0, 4.0)
        parked = npc_row(out.npcs[-1], "parked")
        rear = float(parked["x"] - parked["length"] / 2)  # [m] the lane runs along +x
        _, y, yaw = lane_point(domain.map_reply(), "ZC_2", 2.0)
        track = ego_track("driver", mass_kg=EGO_MASS)
        track.last_pose = pose(t, rear - 0.05 - 4.5 / 2, y, yaw)
        run(domain, out, t, 1.0, egos=lambda now: {"driver": track})
        assert out.impulses == [] and out.events == []


def test_two_egos_head_on_get_equal_and_opposite_impulses(tmp_path: Path, net_cache: Path) -> None:
    quiet = "traffic: {vehicles: {count: 0}, pedestrians: {count: 0}}\n"
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + quiet), net_cache) as domain:
        x, y, yaw = lane_point(domain.map_reply(), "WZ_2", 40.0)
        a, move_a = scripted("a", (x, y, yaw), 5.0, T0)
        b, move_b = scripted("b", (x + 20.0, y, yaw + math.pi), 5.0, T0)

        def egos(now: float) -> dict:
            move_a(now - SAMPLE_AGE_S)
            move_b(now - SAMPLE_AGE_S)
            return {"a": a, "b": b}

        out = MemoryOutbox()
        run(domain, out, T0, 2.0, egos=egos)
        by_node = dict(out.impulses)
        assert set(by_node) == {"a", "b"} and len(out.impulses) == 2
        ia, ib = np.array(by_node["a"].impulse), np.array(by_node["b"].impulse)
        assert ia == pytest.approx(-ib)
        expected = (1 + E) * 10.0 / (2 / EGO_MASS)  # [N·s] closing at 10 m/s
        assert np.linalg.norm(ia) == pytest.approx(expected, rel=0.05)
        assert by_node["a"].other_id == "b" and by_node["b"].other_id == "a"
