"""A config file being edited: its data, checked by the decoder the nodes use, saved only valid.

Validation is `carlaverse config validate`'s own (`config_cmd.validate_file`): the draft is
written to a scratch file beside its target, so references relative to the file (a vehicle, a
trainer table) resolve as they will for the node, and checked there; saving renames that very
file into place, so what was checked is what is saved. Errors come back at their field path:

    road.grade_percent: Expected `float` <= 40.0
"""

from __future__ import annotations

import contextlib
import copy
import importlib
import os
from pathlib import Path
from typing import Any

import msgspec
import yaml

from carlaverse.cli.config_cmd import detect_kind, validate_file
from carlaverse.config import ConfigError, invalid_at, parse_yaml, read_text, resolve_path
from carlaverse.launcher.schema_tree import FILE_SCHEMAS, Section, describe
from carlaverse.node_runtime import load_node_kind, node_kinds


class FieldError(msgspec.Struct, frozen=True):
    path: str  # dotted field path, "" for the file as a whole
    message: str

    def __str__(self) -> str:
        return f"{self.path}: {self.message}" if self.path else self.message


def config_kinds() -> dict[str, type]:
    """Every schema the editor offers: node kinds (entry points) and the other file kinds."""
    kinds = {name: load_node_kind(name).config_type for name in sorted(node_kinds())}
    for kind, (module, name) in FILE_SCHEMAS.items():
        with contextlib.suppress(ImportError):  # an extra not installed: not offered
            kinds[kind] = getattr(importlib.import_module(module), name)
    return kinds


def field_error(exc: ConfigError, known_paths: set[str]) -> FieldError:
    """Where in the file a ConfigError points, and what it says there."""
    path, message = invalid_at(exc.detail)
    if path:
        return FieldError(path, message)
    head, sep, rest = exc.detail.partition(": ")  # cross-field checks: "camera: …"
    if sep and head in known_paths:
        return FieldError(head, rest)
    return FieldError("", exc.detail)


class ConfigDraft:
    """One file's data as edited; `validate()` and `save()` use the node's strict decoder."""

    def __init__(self, kind: str, target: Path, data: dict[str, Any] | None = None) -> None:
        kinds = config_kinds()
        if kind not in kinds:
            raise ConfigError(str(target), f"unknown config kind {kind!r}; one of {list(kinds)}")
        self.kind = kind
        self.target = target
        self.data: dict[str, Any] = data or {}
        self.tree: Section = describe(kinds[kind], kind)
        self._paths = {s.path for s in self.tree.walk()} | {
            leaf.path for s in self.tree.walk() for leaf in s.leaves
        }

    @classmethod
    def open(cls, name: str, target: Path | None = None, kind: str | None = None) -> ConfigDraft:
        """Load a file (a path or a shipped name); it is saved to `target` (default: itself)."""
        path = resolve_path(name)
        data = parse_yaml(read_text(path), str(path))
        return cls(kind or detect_kind(path, data), target or path, data)

    def value(self, path: str) -> Any:
        """The value the file sets at `path`, else the schema's default."""
        node: Any = self.data
        for key in path.split("."):
            if not isinstance(node, dict) or key not in node:
                leaf = self.tree.leaf(path)
                return None if leaf is None else leaf.default
            node = node[key]
        return node

    def set(self, path: str, value: Any) -> None:
        """Set the field at `path`, creating the sections above it."""
        *parents, last = path.split(".")
        node = self.data
        for key in parents:
            child = node.get(key)
            if not isinstance(child, dict):
                child = node[key] = {}
            node = child
        node[last] = value

    def unset(self, path: str) -> None:
        """Remove the field at `path`, so the schema's default applies again."""
        *parents, last = path.split(".")
        node: Any = self.data
        for key in parents:
            node = node.get(key) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(last, None)

    def yaml_text(self) -> str:
        return yaml.safe_dump(copy.deepcopy(self.data), sort_keys=False)

    def validate(self) -> list[FieldError]:
        """[] when the file is valid; else where it is not, by field path."""
        scratch = self._write_scratch()
        try:
            return self._check(scratch)
        finally:
            scratch.unlink(missing_ok=True)

    def save(self) -> list[FieldError]:
        """Write the file if it is valid ([]); otherwise leave it untouched and say why."""
        scratch = self._write_scratch()
        try:
            errors = self._check(scratch)
            if not errors:
                os.replace(scratch, self.target)
            return errors
        finally:
            scratch.unlink(missing_ok=True)

    def _write_scratch(self) -> Path:
        self.target.parent.mkdir(parents=True, exist_ok=True)
        scratch = self.target.with_name(f".{self.target.stem}.launcher-{os.getpid()}.yaml")
        scratch.write_text(self.yaml_text(), encoding="utf-8")
        return scratch

    def _check(self, scratch: Path) -> list[FieldError]:
        try:
            validate_file(str(scratch), self.kind)
        except ConfigError as exc:
            return [field_error(exc, self._paths)]
        return []
