"""A condition's world: the scenario with its overrides merged, written where the trial's
authority reads it, still loading as the scenario it came from (its map files found)."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.study.study_file import Condition, Participant
from carlaverse.study.trial_setup import interpolation_of, merged, node_config, write_scenario
from carlaverse.traffic.scenario import load_scenario


def test_merge_is_deep_for_mappings_only() -> None:
    base = {"weather": {"initial": {"cloudiness": 0.3, "sun_altitude_deg": 50}}, "triggers": [1]}
    over = {"weather": {"initial": {"precipitation": 0.8}}, "triggers": [2, 3]}
    assert merged(base, over) == {
        "weather": {"initial": {"cloudiness": 0.3, "sun_altitude_deg": 50, "precipitation": 0.8}},
        "triggers": [2, 3],  # a list replaces: trigger variants are whole lists
    }


def test_rain_variant_of_the_shipped_crossing(tmp_path: Path) -> None:
    rain = Condition(
        id="rain",
        scenario="crossing",
        seed=11,
        scenario_override={"weather": {"initial": {"precipitation": 0.8, "wetness": 0.6}}},
    )
    target = tmp_path / "trials" / "t01.scenario.yaml"
    target.parent.mkdir()
    assert write_scenario(rain, tmp_path, target) == str(target)
    original, variant = load_scenario("crossing"), load_scenario(target)
    assert variant.spec.seed == 11 and original.spec.seed == 7
    assert variant.spec.weather.initial.precipitation == 0.8
    assert variant.spec.weather.initial.cloudiness == original.spec.weather.initial.cloudiness
    # its map, plain XML files beside the shipped scenario, is still found from elsewhere
    plain = variant.spec.map.plain
    assert plain is not None and original.spec.map.plain is not None
    for name in (plain.nodes, plain.edges, plain.connections):
        assert name is not None and variant.resolve(name).is_file()
    assert variant.resolve(plain.nodes) == original.resolve(original.spec.map.plain.nodes)
    assert write_scenario(Condition(id="bare"), tmp_path, target) == "none"


def test_node_config_override_merges_into_the_participants_file(tmp_path: Path) -> None:
    (tmp_path / "bike.yaml").write_text("node: {kind: bike, pose_rate_hz: 50}\n")
    rider = Participant(id="P02", role="cyclist", kind="bike", config="bike.yaml")
    faster = Condition(id="fast", node_config={"P02": {"node": {"pose_rate_hz": 100}}})
    text = node_config(rider, faster, tmp_path)
    assert "pose_rate_hz: 100" in text and "kind: bike" in text
    assert node_config(Participant(id="P01", role="driver"), faster, tmp_path) == ""
    wrong = Condition(id="wrong", node_config={"P02": {"node": {"pose_rate_hz": "fast"}}})
    with pytest.raises(ConfigError, match=r"condition wrong's node_config.*pose_rate_hz"):
        node_config(rider, wrong, tmp_path)


def test_the_probe_draws_as_the_participants_node_does() -> None:
    assert interpolation_of("").render_mode == "present"  # the kind's default config
    past = interpolation_of("node: {kind: bike, interpolation: {render_mode: past}}\n")
    assert past.render_mode == "past"
    with pytest.raises(ConfigError, match="render_mode"):
        interpolation_of("node: {interpolation: {render_mode: future}}\n")
