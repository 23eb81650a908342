"""`carlaverse config validate FILE…`: check node configs and scenarios before a study."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from carlaverse.config import ConfigError, convert, parse_yaml, read_text, resolve_path
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Validate YAML files against their schema. The schema is chosen with --kind, or from "
        "the file's own `node.kind` field; scenarios are recognised by a top-level `map:`."
    )
    sub = parser.add_subparsers(dest="action", required=True)
    validate = sub.add_parser("validate", help="validate files; exit 1 if any is invalid")
    validate.add_argument("files", nargs="+", help="config or scenario files (or shipped names)")
    validate.add_argument("--kind", help="node kind whose schema to use (observer, scripted, ...)")


def _schema_for(data: Any, kind: str | None) -> tuple[str, type]:
    if isinstance(data, dict) and "map" in data and kind is None:
        from carlaverse.traffic.scenario import Scenario

        return "scenario", Scenario
    if kind is None and isinstance(data, dict):
        node = data.get("node") or {}
        kind = node.get("kind") if isinstance(node, dict) else None
    if kind is None:
        raise ConfigError("", "cannot tell the schema: pass --kind or set node.kind in the file")
    return kind, load_node_kind(kind).config_type


def validate_file(name: str, kind: str | None) -> str:
    path = resolve_path(name)
    data = parse_yaml(read_text(path), str(path))
    try:
        label, schema = _schema_for(data, kind)
    except (ConfigError, UnknownNodeKind) as exc:
        raise ConfigError(str(path), str(exc).lstrip(": ")) from exc
    convert(data, schema, str(path))
    return f"{Path(path)}: valid {label} config"


def run(args: argparse.Namespace) -> int:
    failures = 0
    for name in args.files:
        try:
            print(validate_file(name, args.kind))
        except ConfigError as exc:
            failures += 1
            print(f"error: {exc}", file=sys.stderr)
    return 1 if failures else 0
