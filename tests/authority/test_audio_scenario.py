"""The scenario's `audio:` section: strict validation with the field path, and the shipped town."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.traffic.scenario import load_scenario

MAP = "map: {generate: {kind: grid}}\n"
AMBULANCE = "traffic: {scripted_vehicles: [{id: amb, kind: van, edges: [A0B0]}]}\n"


def scenario(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(f"name: s\n{MAP}{body}", encoding="utf-8")
    return path


def test_the_shipped_town_declares_a_siren_and_a_construction_zone() -> None:
    audio = load_scenario("town").spec.audio
    assert [s.vehicle for s in audio.sirens] == ["ambulance"]
    assert [z.name for z in audio.construction] == ["roadworks-b1c1"]
    assert audio.max_emitters == 32 and audio.rate_hz == 20.0


@pytest.mark.parametrize(
    "body,expected",
    [
        ("audio: {max_emitter: 8}\n", "unknown field `max_emitter` - at `$.audio`"),
        ("audio: {max_emitters: 300}\n", "<= 256 - at `$.audio.max_emitters`"),
        ("audio: {rate_hz: 0}\n", "> 0.0 - at `$.audio.rate_hz`"),
        (AMBULANCE + "audio: {sirens: [{vehicle: amb, pattern: whoop}]}\n",
         "Invalid enum value 'whoop' - at `$.audio.sirens[0].pattern`"),
        ("audio: {construction: [{name: a b, x: 0, y: 0}]}\n", "at `$.audio.construction[0].name`"),
        ("audio: {construction: [{name: a, x: 0, y: 0, radius_m: -1}]}\n",
         ">= 0.0 - at `$.audio.construction[0].radius_m`"),
        ("audio: {construction: [{name: a, x: 0, y: 0}, {name: a, x: 1, y: 1}]}\n",
         "duplicate construction zone name ['a']"),
    ],
)  # fmt: skip
def test_a_bad_audio_section_names_the_field(tmp_path: Path, body: str, expected: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_scenario(scenario(tmp_path, body))
    assert expected in str(err.value) and str(tmp_path) in str(err.value)


def test_a_siren_must_ride_on_a_scripted_or_spawned_vehicle(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"vehicle .ambulance. is not a vehicle of this.*amb"):
        load_scenario(scenario(tmp_path, AMBULANCE + "audio: {sirens: [{vehicle: ambulance}]}\n"))
    spec = load_scenario(scenario(tmp_path, AMBULANCE + "audio: {sirens: [{vehicle: amb}]}\n"))
    assert spec.spec.audio.sirens[0].level_db == 118.0
    spawn = "{type: spawn, id: police, edges: [A0B0]}"
    trigger = f"triggers: [{{id: go, when: 't > 5', actions: [{spawn}]}}]\n"
    spec = load_scenario(scenario(tmp_path, trigger + "audio: {sirens: [{vehicle: police}]}\n"))
    assert spec.spec.audio.sirens[0].vehicle == "police"
