"""The SUMO engine and the domain's stepping: one simulation per process, centre poses,
dead reckoning of egos, and catching up with the session clock after a stall."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from carlaverse.authority.actors import egos_at
from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.traffic.sumo_engine import EngineBusyError, SumoEngine, SumoSettings
from carlaverse.traffic.sumo_tools import import_libsumo
from tests.traffic.helpers import (
    CROSSING_MAP,
    FOLLOWER,
    T0,
    TICK_S,
    domain_of,
    ego_track,
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
    - {id: parked, kind: truck, edges: [ZC], depart_pos_m: 10, stop: {edge: ZC, pos_m: 25}}
"""
STEP_PER_TICK = PARKED + f"  step_length_s: {TICK_S}\n"  # SUMO steps once per authority tick


def test_second_simulation_in_one_process_is_refused(tmp_path: Path, net_cache: Path) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + PARKED), net_cache) as domain:
        net = Path(import_libsumo().simulation.getOption("net-file"))
        with pytest.raises(EngineBusyError, match="close it first"):
            SumoEngine(SumoSettings(net, 1, 0.02))
        assert domain.engine.time_s == 0.0  # the running one is untouched


def test_npc_rows_carry_centre_pose_and_kind(tmp_path: Path, net_cache: Path) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + PARKED), net_cache) as domain:
        out = MemoryOutbox()
        run(domain, out, T0, 5.0)
        row = npc_row(out.npcs[-1], "parked")
        ls = import_libsumo()
        front_x, front_y = ls.vehicle.getPosition("parked")  # SUMO: the front bumper
        assert row["x"] == pytest.approx(front_x - 9.0 / 2, abs=1e-3)  # trucks are 9 m
        assert row["y"] == pytest.approx(front_y, abs=1e-3)
        assert row["yaw"] == pytest.approx(0.0, abs=1e-4)  # ZC runs east
        assert (row["length"], row["width"]) == pytest.approx((9.0, 2.5))
        assert row["kind"] == 2  # messages.ACTOR_KINDS.index("truck")


def test_egos_are_dead_reckoned_to_the_tick_and_observers_have_no_body() -> None:
    driver = ego_track("d")
    driver.last_pose = pose(10.0, 0.0, 0.0, math.pi / 2, speed=4.0)
    watcher = ego_track("o", actor_kind="", kind="observer")
    watcher.last_pose = pose(10.0, 5.0, 5.0)
    fresh = egos_at(10.25, {"d": driver, "o": watcher, "x": ego_track("x")}, 0.5)
    assert [e.node_id for e in fresh] == ["d"]  # no pose yet, no body: not in the world
    assert fresh[0].y == pytest.approx(1.0) and fresh[0].x == pytest.approx(0.0)
    assert egos_at(20.0, {"d": driver}, 0.5)[0].y == pytest.approx(2.0)  # capped at 0.5 s


def test_after_a_stall_the_engine_catches_up_a_little_then_skips(
    tmp_path: Path, net_cache: Path
) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + STEP_PER_TICK), net_cache) as domain:
        out = MemoryOutbox()
        t = run(domain, out, T0, 1.0)  # ticks T0 .. T0 + 0.98: scenario time 0 .. 0.98
        assert domain.engine.time_s == pytest.approx(1.0 - TICK_S)
        domain.tick(t + 0.06, {}, out)  # 0.08 s after the last tick: catch up
        assert domain.engine.time_s == pytest.approx(1.06)
        domain.tick(t + 2.0, {}, out)  # a 2 s stall: 5 steps, the rest is dropped
        assert domain.engine.time_s == pytest.approx(1.06 + 5 * TICK_S)
        assert domain.stats.dropped_s == pytest.approx(2.0 - 0.06 - 5 * TICK_S, abs=1e-6)
        domain.tick(t + 2.0 + TICK_S, {}, out)  # and from there on, one step per tick
        assert domain.engine.time_s == pytest.approx(1.06 + 6 * TICK_S)


def test_between_coarse_steps_npcs_are_dead_reckoned_to_the_tick(
    tmp_path: Path, net_cache: Path
) -> None:
    """SUMO steps every 0.1 s by default, the authority ticks at 50 Hz and sends NPC batches
    at 20 Hz: every batch must show the NPC where it is at the batch's time, not where the
    last step left it (two batches per step would otherwise repeat one position)."""
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + FOLLOWER), net_cache) as domain:
        out = MemoryOutbox()
        run(domain, out, T0, 4.0)
        assert domain.engine.step_length_s == pytest.approx(0.1)
        assert domain.stats.steps == pytest.approx(40, abs=1)  # 10 steps a second, not 50
        moving = [(b.t, npc_row(b, "follower")) for b in out.npcs[-40:] if "follower" in b.ids]
        assert len(moving) >= 30
        for (t0, a), (t1, b) in itertools.pairwise(moving):
            assert a["vx"] > 1.0  # it drives east along WZ
            assert b["x"] - a["x"] == pytest.approx(a["vx"] * (t1 - t0), abs=0.05)
            assert b["x"] != a["x"]


def test_no_tick_both_steps_sumo_and_reads_its_npcs_back(tmp_path: Path, net_cache: Path) -> None:
    """SUMO's step and the read-back of every NPC are the tick's two big costs: the tick that
    steps dead-reckons the frame it has and the next tick reads the step back, so the two
    never add up on one tick, and every batch still shows the NPC where it is."""
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + FOLLOWER), net_cache) as domain:
        engine, calls = domain.engine, []
        for name in ("step", "npcs"):
            inner = getattr(engine, name)

            def traced(inner: Callable[[], Any] = inner, name: str = name) -> Any:
                calls.append((name, engine._unread))  # a read happens only if unread
                return inner()

            setattr(engine, name, traced)
        out, per_tick = MemoryOutbox(), []

        def mark(t: float) -> None:
            per_tick.append([name for name, unread in calls if name == "step" or unread])
            calls.clear()

        run(domain, out, T0, 3.0, every=mark)
        steps = [k for k, work in enumerate(per_tick) if "step" in work]
        assert len(steps) == pytest.approx(30, abs=1)
        assert all(work in ([], ["step"], ["npcs"]) for work in per_tick[1:]), per_tick[:12]
        assert all(per_tick[k + 1] == ["npcs"] for k in steps if k + 1 < len(per_tick))
        moving = [(b.t, npc_row(b, "follower")) for b in out.npcs[-30:] if "follower" in b.ids]
        for (t0, a), (t1, b) in itertools.pairwise(moving):
            assert b["x"] - a["x"] == pytest.approx(a["vx"] * (t1 - t0), abs=0.05)


def test_egos_off_the_network_do_not_break_the_tick(tmp_path: Path, net_cache: Path) -> None:
    body = CROSSING_MAP + "traffic: {vehicles: {count: 2}, pedestrians: {count: 0}}\n"
    with domain_of(write_scenario(tmp_path, body), net_cache) as domain:
        far = ego_track("far")  # SUMO carries a vehicle off-road
        far.last_pose = pose(T0, 5000.0, 5000.0)
        lost = ego_track("lost", actor_kind="pedestrian", kind="walk")  # no sidewalk near
        lost.last_pose = pose(T0, 5000.0, 5000.0)
        out = MemoryOutbox()
        run(domain, out, T0, 3.0, egos=lambda t: {"far": far, "lost": lost})
        # The walker is retried once per second, not every tick; counted, never raised.
        assert 2 <= domain.engine.ego_failures <= 4
        report = domain.report()  # what the authority's --json summary shows as `traffic`
        assert report["ego_failures"] == domain.engine.ego_failures and report["ticks"] >= 150
        assert len(out.npcs) >= 59 and out.npcs[-1].ids  # the world went on


class Held:
    """The domain's real engine, reporting a step still running elsewhere while `held`."""

    def __init__(self, engine: Any) -> None:
        self.engine = engine
        self.held = False

    def __getattr__(self, name: str) -> Any:
        return getattr(self.engine, name)

    @property
    def stepping(self) -> bool:
        return self.held

    def step(self) -> None:
        assert not self.held, "stepped while the step before still ran"
        self.engine.step()


def test_a_tick_leaves_the_step_to_a_later_one_while_sumo_still_steps(
    tmp_path: Path, net_cache: Path
) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + STEP_PER_TICK), net_cache) as domain:
        held = Held(domain.engine)
        domain._engine = held  # type: ignore[assignment]
        out = MemoryOutbox()
        t = run(domain, out, T0, 0.2)  # scenario time 0 .. 0.18, a step a tick
        s = t - T0  # scenario time of the next tick: 0.2
        assert held.time_s == pytest.approx(s - TICK_S)
        held.held = True
        for k in range(3):  # three ticks while SUMO is busy: none of them waits or steps
            domain.tick(t + k * TICK_S, {}, out)
        assert held.time_s == pytest.approx(s - TICK_S)
        assert domain.stats.deferred_steps == 3
        held.held = False
        domain.tick(t + 3 * TICK_S, {}, out)  # free again: caught up, nothing dropped
        assert held.time_s == pytest.approx(s + 3 * TICK_S)
        assert domain.stats.dropped_s == 0.0
        held.held = True  # busy for longer than a catch-up (5 steps): the lag is dropped
        domain.tick(t + 12 * TICK_S, {}, out)
        assert held.time_s == pytest.approx(s + 3 * TICK_S)
        assert domain.stats.dropped_s == pytest.approx(9 * TICK_S)
        held.held = False
        domain.tick(t + 13 * TICK_S, {}, out)  # and on from the session's time
        assert held.time_s == pytest.approx(s + 4 * TICK_S)
