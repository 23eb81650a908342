"""What a trial runs with: its scenario file and each participant's node config, with the
condition's overrides merged in and checked by the decoders that will read them for real.

`check_materials` runs at `study validate`, so an override that names a field the scenario or
the node kind does not have fails before the first participant sits down.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from carlaverse.config import ConfigError, convert, parse_yaml, read_text, resolve_path
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind
from carlaverse.study.study_file import Condition, Participant, Study
from carlaverse.world.remote_actor import InterpolationSettings

NO_SCENARIO = "none"
# Scenario fields that name files relative to the scenario's own folder: made absolute when a
# merged scenario is written elsewhere.
_MAP_FILES = ("net", "opendrive", "osm", "polygons")
_PLAIN_FILES = ("nodes", "edges", "connections")


def merged(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """`base` with `override` merged in: mappings merge key by key, anything else replaces."""
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merged(out[key], value)
        else:
            out[key] = value
    return out


def scenario_data(condition: Condition, study_dir: Path) -> tuple[dict[str, Any], Path] | None:
    """The condition's scenario as data, overrides merged, and its file (None: no scenario)."""
    if condition.scenario == NO_SCENARIO:
        return None
    path = resolve_path(condition.scenario, study_dir)
    data = parse_yaml(read_text(path), str(path))
    if not isinstance(data, dict):
        raise ConfigError(str(path), "expected a mapping of fields at the top level")
    data = merged(data, condition.scenario_override)
    if condition.seed is not None:
        data["seed"] = condition.seed
    return _absolute(data, path.parent), path


def write_scenario(condition: Condition, study_dir: Path, target: Path) -> str:
    """The scenario argument of the trial's authority: `none`, or a file written to `target`."""
    found = scenario_data(condition, study_dir)
    if found is None:
        return NO_SCENARIO
    target.write_text(yaml.safe_dump(found[0], sort_keys=False))
    return str(target)


def node_config(participant: Participant, condition: Condition, study_dir: Path) -> str:
    """The participant's node config in this condition as YAML ("": the kind's own)."""
    override = condition.node_config.get(participant.id, {})
    if participant.config is None and not override:
        return ""
    base: dict[str, Any] = {}
    source = f"participant {participant.id}'s node config"
    if participant.config is not None:
        path = resolve_path(participant.config, study_dir)
        source = str(path)
        loaded = parse_yaml(read_text(path), source)
        base = loaded if isinstance(loaded, dict) else {}
    data = merged(base, override)
    _check_node(participant.kind, data, f"{source} with condition {condition.id}'s node_config")
    return yaml.safe_dump(data, sort_keys=False)


def interpolation_of(config_yaml: str) -> InterpolationSettings:
    """How the node with this config draws the others (`node.interpolation`), so a probe of
    its view draws them alike; the default for the kind's own config ("")."""
    data = yaml.safe_load(config_yaml) if config_yaml else None
    node = data.get("node") if isinstance(data, dict) else None
    found = node.get("interpolation") if isinstance(node, dict) else None
    if found is None:
        return InterpolationSettings()
    return convert(found, InterpolationSettings, "node.interpolation")


def check_materials(study: Study, study_dir: Path) -> None:
    """Every condition's scenario and every participant's node config decode; ConfigError
    naming the file (or the condition) and the field if one does not."""
    from carlaverse.traffic.scenario import ScenarioSpec

    for condition in study.conditions:
        found = scenario_data(condition, study_dir)
        if found is not None:
            where = f"{found[1]} with condition {condition.id}'s overrides"
            convert(found[0], ScenarioSpec, where)
        for participant in study.participants:
            node_config(participant, condition, study_dir)


def _check_node(kind: str, data: dict[str, Any], source: str) -> None:
    try:
        config_type = load_node_kind(kind).config_type
    except UnknownNodeKind as exc:
        raise ConfigError(source, str(exc)) from exc
    convert(data, config_type, source)


def _absolute(data: dict[str, Any], folder: Path) -> dict[str, Any]:
    """Relative file names of the scenario made absolute against its own folder."""
    source = dict(data.get("map") or {})
    for key in _MAP_FILES:
        if isinstance(source.get(key), str):
            source[key] = str(folder / source[key])
    plain = source.get("plain")
    if isinstance(plain, dict):
        source["plain"] = {
            k: str(folder / v) if k in _PLAIN_FILES and isinstance(v, str) else v
            for k, v in plain.items()
        }
    out = dict(data, map=source) if "map" in data else dict(data)
    if isinstance(out.get("openscenario"), str):
        out["openscenario"] = str(folder / out["openscenario"])
    return out
