"""The config editor's model: a tree from the schema, errors at the field path from the nodes'
own decoder, and files written only when valid (read back)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from carlaverse.config import ConfigError, load_config
from carlaverse.launcher.config_draft import ConfigDraft, FieldError, config_kinds, field_error
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.schema_tree import describe
from carlaverse.physics.bicycle import BicycleParams


def test_every_node_kind_and_file_kind_has_a_tree() -> None:
    kinds = config_kinds()
    assert {"observer", "scripted", "drive", "bike", "scenario", "vehicle"} <= set(kinds)
    for kind, config_type in kinds.items():
        tree = describe(config_type, kind)
        assert tree.walk()[0] is tree and (tree.leaves or tree.sections), kind


def test_leaves_carry_kind_bounds_and_default(tmp_path: Path) -> None:
    tree = describe(BicycleParams)
    mass = tree.leaf("mass_kg")
    assert mass is not None and (mass.kind, mass.bounds, mass.default) == ("number", "> 0", 90.0)
    bike = ConfigDraft("bike", Path("unused.yaml"), ConfigDir(tmp_path)).tree
    grade = bike.leaf("road.grade_percent")
    assert grade is not None and grade.bounds == ">= -40, <= 40"
    assert set(bike.leaf("speed_source").choices) == {"trainer", "speed_sensor"}
    assert bike.leaf("trainer.options").kind == "yaml"  # a mapping: edited as YAML text
    assert "road" in [s.path for s in bike.walk()]


def test_bad_value_is_named_at_its_path_and_not_saved(tmp_path: Path) -> None:
    target = tmp_path / "bike.yaml"
    draft = ConfigDraft.open(ConfigDir(tmp_path), "bike-sim", target)
    draft.set("bicycle.mass_kg", -5)
    errors = draft.save()
    assert errors == [FieldError("bicycle.mass_kg", "Expected `float` > 0.0")]
    assert str(errors[0]) == "bicycle.mass_kg: Expected `float` > 0.0"
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # no scratch file left either


def test_unknown_field_and_wrong_type_are_named_too(tmp_path: Path) -> None:
    draft = ConfigDraft("bike", tmp_path / "b.yaml", ConfigDir(tmp_path))
    draft.set("road.grade", 3)
    assert draft.validate() == [FieldError("road", "Object contains unknown field `grade`")]
    draft.unset("road.grade")
    draft.set("loop.rate_hz", "fast")
    assert draft.validate() == [FieldError("loop.rate_hz", "Expected `float`, got `str`")]


def test_good_value_is_saved_and_read_back_by_the_node_decoder(tmp_path: Path) -> None:
    from carlaverse_nodes.bike.config import BikeNodeConfig

    target = tmp_path / "sub" / "bike.yaml"  # a folder inside the config dir is made
    files = ConfigDir(tmp_path)
    draft = ConfigDraft.open(files, "bike-sim", target)
    draft.set("road.grade_percent", 7.5)
    assert draft.save() == []
    assert yaml.safe_load(target.read_text())["road"]["grade_percent"] == 7.5
    assert load_config(target, BikeNodeConfig).road.grade_percent == 7.5
    assert ConfigDraft.open(files, str(target)).value("road.grade_percent") == 7.5
    assert draft.value("road.roughness") == 0.2  # set by the shipped file
    draft.unset("road.roughness")
    assert draft.value("road.roughness") == 0.2  # now the schema's default


def test_cross_field_error_lands_on_its_section() -> None:
    error = field_error(ConfigError("x.yaml", "fabric: bad endpoint 'tcp/nowhere'"), {"fabric"})
    assert error == FieldError("fabric", "bad endpoint 'tcp/nowhere'")
    assert field_error(ConfigError("x.yaml", "something else"), set()).path == ""


def test_unknown_kind_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="unknown config kind 'bicycle'"):
        ConfigDraft("bicycle", Path("x.yaml"), ConfigDir(tmp_path))


def test_status_follows_the_edits_and_never_keeps_a_stale_error(tmp_path: Path) -> None:
    """The editor's status line (issue 43.8): after a refused save it said "not saved: <error>"
    and kept saying it once the field was set right. The bike schema bounds road.grade_percent
    to ≤ 40 (the node's own decoder): 99 is refused, 5.5 is fine."""
    target = tmp_path / "bike.yaml"
    draft = ConfigDraft.open(ConfigDir(tmp_path), "bike-sim", target)
    draft.set("road.grade_percent", 99)
    assert draft.save() != []
    text, ok = draft.status()
    assert not ok and text.startswith("not saved: road.grade_percent: Expected `float` <= 40")
    draft.set("road.grade_percent", 5.5)
    draft.validate()
    text, ok = draft.status()
    assert ok and "grade_percent" not in text and "not saved:" not in text, text
    draft.set("loop.rate_hz", "fast")  # another field wrong: its error, not the old one
    draft.validate()
    assert draft.status() == ("not valid: loop.rate_hz: Expected `float`, got `str`", False)
    draft.unset("loop.rate_hz")
    assert draft.save() == []
    assert draft.status() == (f"saved {target}", True)
