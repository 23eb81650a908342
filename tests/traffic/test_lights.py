"""Traffic lights: the published sequence follows the program's phases and durations."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.config import ConfigError
from carlaverse.messages import LIGHTS, LightsState
from tests.traffic.helpers import CROSSING_MAP, T0, TICK_S, domain_of, run, write_scenario

QUIET = "traffic: {vehicles: {count: 0}, pedestrians: {count: 0}}\n"


def switches(states: list[LightsState], light_id: str) -> list[tuple[float, int, str]]:
    """(time, phase, state) at every published phase change of one light."""
    out: list[tuple[float, int, str]] = []
    for msg in states:
        light = next(x for x in msg.lights if x.id == light_id)
        if not out or out[-1][1] != light.phase:
            out.append((msg.t, light.phase, light.state))
    return out


def test_published_sequence_matches_the_program(tmp_path: Path, net_cache: Path) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + QUIET), net_cache) as domain:
        program = domain.engine.light_programs()["C"]
        cycle = sum(p.duration_s for p in program)
        out = MemoryOutbox()
        run(domain, out, T0, cycle + 10.0)
        seen = switches(out.lights_states, "C")
        assert [s[1] for s in seen[: len(program) + 1]] == [*range(len(program)), 0]
        for (t0, phase, state), (t1, _, _) in itertools.pairwise(seen):
            assert state == program[phase].state
            if t0 > T0:  # the first phase was entered before the first tick
                assert t1 - t0 == pytest.approx(program[phase].duration_s, abs=TICK_S + 1e-9)
        # Between switches the state is repeated at 1 Hz, with the remaining phase time.
        gaps = [b.t - a.t for a, b in itertools.pairwise(out.lights_states)]
        assert max(gaps) <= 1.0 + 1e-6
        for msg in out.lights_states:
            light = msg.lights[0]
            assert 0.0 <= light.remaining_s <= program[light.phase].duration_s
        assert LIGHTS.decode(LIGHTS.encode(out.lights_states[-1])) == out.lights_states[-1]


OVERRIDE = """
lights:
  - id: C
    offset_s: 2
    phases:
      - {duration_s: 10, state: GGGGGGrrrrrrGGGGGGrrrrrrrrrr}
      - {duration_s: 3, state: yyyyyyrrrrrryyyyyyrrrrrrrrrr}
      - {duration_s: 12, state: rrrrrrGGGGGGrrrrrrGGGGGGGrGr}
      - {duration_s: 3, state: rrrrrryyyyyyrrrrrryyyyyyrrrr}
"""


def test_scenario_override_replaces_the_program(tmp_path: Path, net_cache: Path) -> None:
    scenario = write_scenario(tmp_path, CROSSING_MAP + QUIET + OVERRIDE)
    with domain_of(scenario, net_cache) as domain:
        out = MemoryOutbox()
        run(domain, out, T0, 40.0)
        seen = switches(out.lights_states, "C")
        durations = [10, 3, 12, 3]
        # offset 2 s: the cycle is at -2 s (= 26 s, in the last phase) at engine time 0
        assert seen[0][1] == 3 and seen[0][2].startswith("rrrrrryyyyyy")
        for (t0, phase, _), (t1, _, _) in itertools.pairwise(seen[1:]):
            assert t1 - t0 == pytest.approx(durations[phase], abs=TICK_S + 1e-9)
        assert [s[1] for s in seen[:5]] == [3, 0, 1, 2, 3]


def test_override_of_a_missing_light_names_the_scenario(tmp_path: Path, net_cache: Path) -> None:
    bad = OVERRIDE.replace("id: C", "id: X")
    scenario = write_scenario(tmp_path, CROSSING_MAP + QUIET + bad)
    with pytest.raises(ConfigError, match=r"test\.yaml.*no traffic light 'X'.*\['C'\]"):
        domain_of(scenario, net_cache).__enter__()


def test_override_with_a_wrong_state_length_is_refused(tmp_path: Path, net_cache: Path) -> None:
    bad = OVERRIDE.replace("GGGGGGrrrrrrGGGGGGrrrrrrrrrr", "GGrr")
    scenario = write_scenario(tmp_path, CROSSING_MAP + QUIET + bad)
    with pytest.raises(ConfigError, match="controls 28 links"):
        domain_of(scenario, net_cache).__enter__()


def test_lights_read_once_per_step_and_a_set_state_shows_at_once(
    tmp_path: Path, net_cache: Path
) -> None:
    with domain_of(write_scenario(tmp_path, CROSSING_MAP + QUIET), net_cache) as domain:
        engine = domain.engine
        run(domain, MemoryOutbox(), T0, 1.0)
        first = engine.light_readings()
        assert engine.light_readings() is first  # same engine time: SUMO is not asked again
        links = len(first[0].state)
        engine.set_light_state("C", "r" * links)
        assert {r.id: r.state for r in engine.light_readings()}["C"] == "r" * links
        engine.step()
        after = engine.light_readings()
        assert after is not first and after == engine.light_readings()
