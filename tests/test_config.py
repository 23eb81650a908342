from __future__ import annotations

from pathlib import Path
from typing import Annotated

import msgspec
import pytest

from carlaverse.cli import main
from carlaverse.config import ConfigError, StrictStruct, load_config, resolve_path
from carlaverse.patterns import anchored, readable


class Spring(StrictStruct):
    stiffness: Annotated[float, msgspec.Meta(ge=0)] = 1.0


class Ffb(StrictStruct):
    spring: Spring = Spring()


class NodeCfg(StrictStruct):
    ffb: Ffb = Ffb()


def test_error_names_the_file_and_the_field_path(tmp_path: Path) -> None:
    f = tmp_path / "drive.yaml"
    f.write_text("ffb:\n  spring:\n    stiffness: -3\n")
    with pytest.raises(ConfigError) as err:
        load_config(f, NodeCfg)
    assert str(f) in str(err.value) and "$.ffb.spring.stiffness" in str(err.value)
    assert ">= 0" in str(err.value)


def test_unknown_fields_are_rejected_by_name(tmp_path: Path) -> None:
    f = tmp_path / "drive.yaml"
    f.write_text("ffb:\n  sprung: {}\n")
    with pytest.raises(ConfigError, match=r"unknown field `sprung`.*\$\.ffb"):
        load_config(f, NodeCfg)


def test_yaml_syntax_errors_give_the_line(tmp_path: Path) -> None:
    f = tmp_path / "bad.yaml"
    f.write_text("ffb:\n  spring: [\n")
    # The flow sequence opened on line 2 is still open at the end of the text: line 3, column 1.
    with pytest.raises(ConfigError, match=rf"^{f}:3:1: invalid YAML: expected the node content"):
        load_config(f, NodeCfg)


def test_paths_resolve_absolute_relative_and_shipped(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    target = tmp_path / "sub" / "x.yaml"
    target.write_text("{}")
    assert resolve_path(target) == target
    assert resolve_path("sub/x.yaml", relative_to=tmp_path) == target
    with pytest.raises(ConfigError, match="no such file"):
        resolve_path("does-not-exist.yaml", relative_to=tmp_path)


def test_shipped_configs_resolve_by_name() -> None:
    shipped = sorted(p.name for p in resolve_path.__globals__["shipped_dir"]().glob("*.yaml"))
    if not shipped:
        pytest.skip("no shipped config yet")
    assert resolve_path(shipped[0].removesuffix(".yaml")).name == shipped[0]


def test_config_validate_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = tmp_path / "s.yaml"
    good.write_text("node: {kind: scripted, node_id: s1}\npath: {type: circle, radius: 12}\n")
    bad = tmp_path / "b.yaml"
    bad.write_text("node: {kind: scripted}\npath: {type: circle, radius: -1}\n")
    assert main(["config", "validate", str(good)]) == 0
    assert main(["config", "validate", str(good), str(bad)]) == 2  # a config error (the table)
    err = capsys.readouterr().err
    assert "b.yaml" in err and "$.path.radius" in err


def test_a_pattern_in_a_config_error_is_said_in_words_not_as_a_regex(tmp_path: Path) -> None:
    """`layout: 7.1` in an audio config (issue 43.8): the error names the field and the
    layouts there are, as `--layout 7.1` on the command line does, with no regex in it."""
    from carlaverse.audio.config import AudioConfig

    bad = tmp_path / "audio.yaml"
    bad.write_text("layout: '7.1'\n")
    with pytest.raises(ConfigError) as caught:
        load_config(bad, AudioConfig)
    said = str(caught.value)
    assert "binaural, stereo, quad, 5.1 or ringN" in said and "$.layout" in said, said
    assert "regex" not in said and "(?!" not in said and "^(?:" not in said, said


class _Light(msgspec.Struct):
    state: Annotated[str, msgspec.Meta(pattern=anchored("[rygGoOsu]+"))]


def test_a_pattern_without_words_loses_only_its_anchors() -> None:
    try:
        msgspec.convert({"state": "blue"}, _Light)
    except msgspec.ValidationError as exc:
        said = readable(str(exc))
    assert said == "Expected text of the form `[rygGoOsu]+` - at `$.state`", said
