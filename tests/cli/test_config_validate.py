"""`carlaverse config validate` accepts every file the project ships, by path or by name, and
rejects a broken one naming the file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.cli import main

REPO = Path(__file__).resolve().parents[2]
NOT_SHIPPED = {".venv", ".git", "tests", "build", "dist", ".pytest_cache", ".ruff_cache"}
# What each shipped file must be recognised as (a file here under another schema is a bug).
EXPECTED = {
    "examples/studies/latency-dyad.yaml": "study",
    "scenarios/town.yaml": "scenario",
    "scenarios/crossing.yaml": "scenario",
    "scenarios/ring.yaml": "scenario",
    "configs/vehicles/compact-car.yaml": "vehicle",
    "configs/vehicles/van.yaml": "vehicle",
    "configs/drive-cabin.yaml": "drive node",
    "configs/drive-desktop.yaml": "drive node",
    "configs/drive-wheel.yaml": "drive node",
    "router/session.example.yaml": "roster",
    "router/session.local.yaml": "roster",
    "router/site-plain.yaml": "router",
    "router/zenohd-site.json5": "zenohd",
    "configs/bike-sim.yaml": "bike node",
    "configs/bike-trainer-table.yaml": "trainer-table",
    "configs/hmi/drive.yaml": "hmi",
    "configs/hmi/bike.yaml": "hmi",
    "configs/rigs/rig-bike-desktop.yaml": "rig",
    "configs/rigs/rig-cave.yaml": "rig",
    "configs/rigs/rig-desktop.yaml": "rig",
    "configs/rigs/rig-three-displays.yaml": "rig",
    "configs/walk-sim.yaml": "walk node",
    "configs/walk-desktop.yaml": "walk node",
    "configs/walk-vr.yaml": "walk node",
    "configs/rigs/rig-walk-desktop.yaml": "rig",
    "configs/rigs/rig-walk-vr.yaml": "rig",
    "configs/audio/headphones.yaml": "audio",
    "configs/audio/headless.yaml": "audio",
    "configs/audio/speakers-5.1.yaml": "audio",
    "configs/audio/ring8.yaml": "audio",
}


def shipped_files() -> list[str]:
    """Every YAML or json5 file of the checkout outside tests and tool caches."""
    found = [
        p.relative_to(REPO).as_posix()
        for suffix in ("*.yaml", "*.yml", "*.json5")
        for p in REPO.rglob(suffix)
        if not NOT_SHIPPED & set(p.relative_to(REPO).parts)
    ]
    return sorted(found)


def test_the_expected_list_covers_every_shipped_file() -> None:
    assert set(shipped_files()) == set(EXPECTED), "a new shipped file: add it to EXPECTED"


@pytest.mark.parametrize("relative", shipped_files())
def test_every_shipped_file_is_valid(relative: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["config", "validate", str(REPO / relative)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert out.strip() == f"{REPO / relative}: valid {EXPECTED[relative]} config"


@pytest.mark.parametrize("name", ["town", "crossing", "ring", "drive-desktop", "compact-car"])
def test_shipped_files_by_name(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["config", "validate", name]) == 0, capsys.readouterr().err
    assert "valid" in capsys.readouterr().out


def test_a_broken_scenario_names_the_file_and_the_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (REPO / "scenarios/town.yaml").read_text()
    broken = tmp_path / "town-broken.yaml"
    broken.write_text(text + "\nmystery_field: 1\n")
    assert main(["config", "validate", str(broken)]) == 2  # a config error, as in `join`
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert str(broken) in err and "mystery_field" in err


def test_a_node_config_with_a_bad_endpoint_is_rejected(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "car.yaml"
    config.write_text("node: {kind: scripted}\nfabric: {connect: ['127.0.0.1:7447']}\n")
    assert main(["config", "validate", str(config)]) == 2  # a config error, as in `join`
    err = capsys.readouterr().err
    assert "bad --connect endpoint '127.0.0.1:7447'" in err and ".rs:" not in err


def test_a_file_of_no_known_kind_says_how_to_choose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    odd = tmp_path / "odd.yaml"
    odd.write_text("colour: blue\n")
    assert main(["config", "validate", str(odd)]) == 2  # a config error, as in `join`
    assert "pass --kind" in capsys.readouterr().err
    assert main(["config", "validate", "--kind", "vehicle", str(odd)]) == 2
    assert "unknown field `colour`" in capsys.readouterr().err


def test_a_walk_configs_body_options_are_checked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "walk.yaml"
    config.write_text("node: {kind: walk}\nbody: {source: camera, options: {rate_hz: 0}}\n")
    assert main(["config", "validate", str(config)]) == 2  # a config error, as in `join`
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(config) in err
    assert "body.options" in err and "rate_hz" in err
    config.write_text("node: {kind: walk}\nbody: {source: camera, options: {cpu: any}}\n")
    assert main(["config", "validate", str(config)]) == 0, capsys.readouterr().err
