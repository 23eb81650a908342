"""Which schema a config file follows, and its check by the decoder that will read it for real.

`carlaverse config validate` and the launcher's config editor check files here, so a file is
judged the same from a terminal and from the page; errors are ConfigErrors naming file and field.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from carlaverse.config import (
    ConfigError,
    StrictStruct,
    convert,
    parse_yaml,
    read_text,
    resolve_path,
)
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind
from carlaverse.transport.session import FabricSettings


class RouterConfig(StrictStruct):
    """A router's config file (`carlaverse router --config`): its fabric alone."""

    fabric: FabricSettings = FabricSettings(mode="router")


# File kinds that are not node kinds, each told apart by its top-level fields.
FILE_KINDS = (
    "scenario", "vehicle", "roster", "router", "rig", "trainer-table", "hmi", "zenohd", "audio",
    "study",
)  # fmt: skip


def detect_kind(path: Path, data: Any) -> str:
    """Which schema a file follows, from its suffix and top-level fields."""
    if path.suffix == ".json5":
        return "zenohd"
    if not isinstance(data, dict):
        raise ConfigError(str(path), "expected a mapping of fields at the top level")
    node = data.get("node")
    if isinstance(node, dict) and node.get("kind"):
        return str(node["kind"])
    for kind, fields in (("scenario", {"map"}), ("vehicle", {"body", "spec"}),
                         ("roster", {"sites", "nodes"}), ("router", {"fabric"}),
                         ("rig", {"camera"}), ("hmi", {"layouts"}),
                         ("trainer-table", {"resistance_percent"}),
                         ("audio", {"layout"}),
                         ("study", {"participants", "conditions"})):  # fmt: skip
        if fields <= data.keys() and (kind != "router" or data.keys() == {"fabric"}):
            return kind
    raise ConfigError(str(path), "cannot tell the schema: pass --kind or set node.kind in the file")


def validate_file(name: str, kind: str | None) -> str:
    """Validate one file; return the line to print, raise ConfigError naming file and field."""
    path = _resolve(name)
    data = None if path.suffix == ".json5" else parse_yaml(read_text(path), str(path))
    kind = kind or detect_kind(path, data)
    check = CHECKS.get(kind, _check_node)
    check(path, data, kind)
    label = kind if kind in FILE_KINDS else f"{kind} node"
    return f"{path}: valid {label} config"


def _resolve(name: str) -> Path:
    """A path, or a shipped name: `town`, `drive-desktop`, and vehicles by bare name too."""
    try:
        return resolve_path(name)
    except ConfigError:
        if "/" in name:
            raise
        try:
            return resolve_path(f"vehicles/{name}")
        except ConfigError:
            pass
        raise


def _check_scenario(path: Path, data: Any, kind: str) -> None:
    from carlaverse.traffic.scenario import load_scenario

    load_scenario(path)  # also the OpenSCENARIO file it names


def _check_vehicle(path: Path, data: Any, kind: str) -> None:
    from carlaverse.physics.params import load_vehicle

    load_vehicle(path)  # also the range and cross-field checks


def _check_roster(path: Path, data: Any, kind: str) -> None:
    from carlaverse.security.roster import load_roster

    load_roster(path)  # also names, sites, the authority and unique identities


def _check_router(path: Path, data: Any, kind: str) -> None:
    _check_fabric(path, convert(data, RouterConfig, str(path)).fabric)


def _check_rig(path: Path, data: Any, kind: str) -> None:
    from carlaverse.render.rig import RenderConfig, layout

    rig = convert(data, RenderConfig, str(path))
    try:
        layout(rig.camera)  # the paper's formulas reject displays that leave no picture
    except ValueError as exc:
        raise ConfigError(str(path), f"camera: {exc}") from exc


def _check_trainer_table(path: Path, data: Any, kind: str) -> None:
    from carlaverse.hal.trainer.resistance_table import load_table

    load_table(path)  # also strictly increasing axes and the table's shape


def _check_hmi(path: Path, data: Any, kind: str) -> None:
    from carlaverse.hmi.config import load_hmi_config

    load_hmi_config(str(path))  # also its pages_dir


def _check_zenohd(path: Path, data: Any, kind: str) -> None:
    import zenoh

    from carlaverse.transport.session import zenoh_reason

    try:
        zenoh.Config.from_file(str(path))
    except Exception as exc:  # zenoh raises ZError with the json5 parser's message
        raise ConfigError(str(path), zenoh_reason(exc)) from exc


def _check_audio(path: Path, data: Any, kind: str) -> None:
    from carlaverse.audio.config import AudioConfig

    convert(data, AudioConfig, str(path))


def _check_study(path: Path, data: Any, kind: str) -> None:
    from carlaverse.study.schedule import plan, shared_conflict
    from carlaverse.study.study_file import load_study
    from carlaverse.study.trial_setup import check_materials

    study = load_study(path)  # also pseudonyms, known participants and conditions
    conflict = shared_conflict(study, plan(study))
    if conflict:
        raise ConfigError(str(path), conflict)
    check_materials(study, path.parent)  # every scenario and node config it names


def _check_node(path: Path, data: Any, kind: str) -> None:
    try:
        node_type = load_node_kind(kind)
    except UnknownNodeKind as exc:
        raise ConfigError(str(path), str(exc)) from exc
    # The kind's own config type; NodeKind promises only its `node` and `fabric` sections.
    config: Any = convert(data, node_type.config_type, str(path))
    _check_fabric(path, config.fabric)
    check = getattr(node_type, "check_config", None)  # a kind's own checks across fields
    if check is not None:
        try:
            check(config)
        except ConfigError as exc:
            raise ConfigError(str(path), str(exc)) from exc


def _check_fabric(path: Path, fabric: Any) -> None:
    """Endpoints and raw Zenoh entries, as the session will be opened with them."""
    from carlaverse.transport.session import FabricError, build_config

    try:
        build_config(fabric)
    except FabricError as exc:
        raise ConfigError(str(path), f"fabric: {exc}") from exc


CHECKS: dict[str, Callable[[Path, Any, str], None]] = {
    "scenario": _check_scenario,
    "vehicle": _check_vehicle,
    "roster": _check_roster,
    "router": _check_router,
    "rig": _check_rig,
    "trainer-table": _check_trainer_table,
    "hmi": _check_hmi,
    "zenohd": _check_zenohd,
    "audio": _check_audio,
    "study": _check_study,
}
