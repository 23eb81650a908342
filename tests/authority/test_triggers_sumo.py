"""Scenario triggers on real SUMO: the same pull-out encounter for every cyclist, and actions.

The crossing map: a cyclist rides north on the bike lane SC_1 (x = 164.05) into the junction;
a car waits on the west arm (ZC, car lane at y = 118.35) and goes straight across. Their
paths cross at (164.05, 118.35). The trigger releases the car when the cyclist is 6 s from
that point, timed so that the car's front reaches it when the cyclist is `TARGET_TTC_S` away.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.config import ConfigError
from carlaverse.messages import Extent, Notice, TriggerFired
from carlaverse.traffic.scenario import load_scenario
from tests.traffic.helpers import (
    CROSSING_CONFLICT,
    CROSSING_MAP,
    T0,
    TICK_S,
    domain_of,
    ego_track,
    net_cache,
    pose,
    write_scenario,
)

__all__ = ["net_cache"]  # a fixture, imported for pytest
CONFLICT = CROSSING_CONFLICT
TARGET_TTC_S = 2.0
BIKE = Extent(1.8, 0.6, 1.7)
CAR_LENGTH_M = 4.5  # the `car` NPC type

PULL_OUT = f"""
{CROSSING_MAP}
session: {{npc_rate_hz: 50}}
traffic:
  vehicles: {{count: 0}}
  pedestrians: {{count: 0}}
  scripted_vehicles:
    - {{id: waiting-car, edges: [ZC, CE], depart_pos_m: 5, stop: {{edge: ZC, pos_m: 30}}}}
triggers:
  - id: pull_out
    measure:
      bike_eta: {{type: eta, actor: bike-1, point: [{CONFLICT[0]}, {CONFLICT[1]}]}}
    when: "bike_eta < 6"
    actions:
      - type: release
        npc: waiting-car
        arrive: {{point: [{CONFLICT[0]}, {CONFLICT[1]}], of: bike-1, ttc_s: {TARGET_TTC_S}}}
      - {{type: message, to: bike-1, text: "car ahead", duration_s: 3}}
"""


def _ride(scenario: Path, cache: Path, speed: float, start_m: float) -> tuple[float, TriggerFired]:
    """One cyclist at `speed` from `start_m` south of the point; the TTC when the car's front
    reaches the point, from the NPC batches and the cyclist's own path."""
    track = ego_track("bike-1", actor_kind="bicycle", kind="bike", extent=BIKE)
    y0 = CONFLICT[1] - start_m

    def bike_front_y(t: float) -> float:
        return y0 + speed * (t - T0) + BIKE.length / 2

    out = MemoryOutbox()
    with domain_of(scenario, cache) as domain:
        previous = None
        for k in range(round((start_m / speed + 3) / TICK_S)):
            t = T0 + k * TICK_S
            track.last_pose = pose(t, CONFLICT[0], bike_front_y(t) - BIKE.length / 2,
                                   math.pi / 2, speed)  # fmt: skip
            domain.tick(t, {"bike-1": track}, out)
            front = _car_front_x(out, t)
            if front is not None and front >= CONFLICT[0]:
                # the crossing instant, between this batch and the last one
                (t1, x1), (t2, x2) = previous, (t, front)
                t_cross = t1 + (CONFLICT[0] - x1) / (x2 - x1) * (t2 - t1)
                ttc = (CONFLICT[1] - bike_front_y(t_cross)) / speed
                (fired,) = [e for e in out.events if isinstance(e, TriggerFired)]
                return ttc, fired
            if front is not None:
                previous = (t, front)
    raise AssertionError("the car never reached the conflict point")


def _car_front_x(out: MemoryOutbox, t: float) -> float | None:
    batch = out.npcs[-1] if out.npcs and out.npcs[-1].t == t else None
    if batch is None or "waiting-car" not in batch.ids:
        return None
    row = batch.array()[batch.ids.index("waiting-car")]
    return float(row["x"]) + CAR_LENGTH_M / 2 * math.cos(float(row["yaw"]))


def test_the_car_pulls_out_at_the_target_ttc_for_every_cyclist(tmp_path: Path, net_cache) -> None:
    scenario = write_scenario(tmp_path, PULL_OUT)
    rng = np.random.default_rng(19)
    ttcs = []
    for _ in range(10):
        speed, start = float(rng.uniform(3.5, 6.5)), float(rng.uniform(50.0, 90.0))
        ttc, fired = _ride(scenario, net_cache, speed, start)
        assert fired.actions == ["release waiting-car", "message to bike-1"]
        assert fired.values["bike_eta"] == pytest.approx(6.0, abs=speed * TICK_S / speed + 0.01)
        ttcs.append((round(speed, 2), round(start, 1), round(ttc, 4)))
    print("speed [m/s], start [m], TTC at the conflict point [s]:", ttcs)
    assert all(abs(ttc - TARGET_TTC_S) <= 0.3 for _, _, ttc in ttcs), ttcs


ACTIONS = f"""
{CROSSING_MAP}
traffic:
  vehicles: {{count: 0}}
  pedestrians: {{count: 0}}
triggers:
  - id: storm
    when: "t > 1"
    actions:
      - {{type: weather, precipitation: 0.9, wetness: 0.7}}
      - {{type: light, id: C, state: rrrrrrrrrrrrrrrrrrrrrrrrrrrr}}
      - {{type: spawn, id: late-car, edges: [WZ, ZC], speed_mps: 5}}
  - id: after_storm
    when: "fired_storm > 0 and t > 2"
    actions: [{{type: message, text: "all red"}}]
  - id: bad_npc
    when: "t > 1.5"
    actions: [{{type: release, npc: nobody}}]
"""


def test_actions_reach_the_world_and_every_firing_is_an_event(tmp_path: Path, net_cache) -> None:
    out = MemoryOutbox()
    with domain_of(write_scenario(tmp_path, ACTIONS), net_cache) as domain:
        links = len(domain.engine.light_readings()[0].state)
        for k in range(round(3.0 / TICK_S)):
            domain.tick(T0 + k * TICK_S, {}, out)
        assert {r.id: r.state for r in domain.engine.light_readings()}["C"] == "r" * links
    fired = [e for e in out.events if isinstance(e, TriggerFired)]
    assert [f.trigger_id for f in fired] == ["storm", "bad_npc", "after_storm"]
    assert fired[0].actions[:1] == ["weather precipitation=0.9 wetness=0.7"]
    assert fired[0].actions[2] == "spawn late-car"
    assert fired[1].actions[0].startswith("failed: cannot release nobody")
    assert all(f.t > T0 + 1.0 for f in fired)  # 't' is scenario time: session time since T0
    last = out.weathers[-1]
    assert (last.precipitation, last.wetness) == (0.9, 0.7)
    assert any("late-car" in b.ids for b in out.npcs)
    (notice,) = [e for e in out.events if isinstance(e, Notice)]
    assert (notice.text, notice.to) == ("all red", "")


def test_a_condition_outside_the_grammar_names_the_trigger(tmp_path: Path) -> None:
    bad = write_scenario(tmp_path, f"""{CROSSING_MAP}
triggers:
  - {{id: go, when: "speed > 3", actions: [{{type: message, text: hi}}]}}
""")  # fmt: skip
    with pytest.raises(ConfigError, match=r"trigger go: the name 'speed' is not allowed"):
        load_scenario(bad)


def test_a_condition_that_fails_at_run_time_is_counted_and_the_tick_goes_on(
    tmp_path: Path, net_cache
) -> None:
    """`1 / (t - t)` divides by zero at every tick. It compiles (nothing in it is constant),
    and an exception out of the authority's tick would end the session for everyone: the
    failing trigger must read as not holding, be counted, and leave the others working."""
    scenario = write_scenario(tmp_path, f"""{CROSSING_MAP}
triggers:
  - {{id: broken, when: "1 / (t - t) > 0", actions: [{{type: message, text: never}}]}}
  - {{id: later, when: "t > 0.5", actions: [{{type: message, text: still here}}]}}
""")  # fmt: skip
    out = MemoryOutbox()
    ticks = round(1.0 / TICK_S)
    with domain_of(scenario, net_cache) as domain:
        for k in range(ticks):
            domain.tick(T0 + k * TICK_S, {}, out)
        failed = domain.stats.trigger_failures
    fired = [e.trigger_id for e in out.events if isinstance(e, TriggerFired)]
    assert fired == ["later"]
    assert failed == ticks  # every tick's evaluation of 'broken', none of 'later'
