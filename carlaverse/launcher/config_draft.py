"""A config file being edited: its data, checked by the decoder the nodes use, saved only valid.

Validation is `carlaverse config validate`'s own (`config_check.validate_file`): the draft is
written to a scratch file beside its target, so references relative to the file (a vehicle, a
trainer table) resolve as they will for the node, and checked there; saving renames that very
file into place, so what was checked is what is saved. Errors come back at their field path:

    road.grade_percent: Expected `float` <= 40.0

Every file is opened and saved through the config dir (`launcher.files`): nothing outside it
is read or written, and an error about a file the draft refers to outside it (a vehicle named
by absolute path) says where, never what that file holds.
"""

from __future__ import annotations

import contextlib
import copy
import importlib
from pathlib import Path
from typing import Any

import msgspec
import yaml

from carlaverse.config import ConfigError, invalid_at, parse_yaml
from carlaverse.config_check import detect_kind, validate_file
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.schema_tree import FILE_SCHEMAS, Section, describe
from carlaverse.node_runtime import load_node_kind, node_kinds

OUTSIDE_NOT_SHOWN = "a file outside the config dir does not decode; what it holds is not shown"


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

    def __init__(
        self, kind: str, target: Path, files: ConfigDir, data: dict[str, Any] | None = None
    ) -> None:
        kinds = config_kinds()
        if kind not in kinds:
            raise ConfigError(str(target), f"unknown config kind {kind!r}; one of {list(kinds)}")
        self.kind = kind
        self.target = target  # inside `files`: absolute, or relative to the config dir
        self.files = files
        self.data: dict[str, Any] = data or {}
        self.errors: list[FieldError] = []  # the last check's, by field path
        self.saved: bool | None = None  # the last save since an edit: done, refused, not tried
        self.tree: Section = describe(kinds[kind], kind)
        self._paths = {s.path for s in self.tree.walk()} | {
            leaf.path for s in self.tree.walk() for leaf in s.leaves
        }

    @classmethod
    def open(
        cls, files: ConfigDir, name: str, target: Path | None = None, kind: str | None = None
    ) -> ConfigDraft:
        """Load a file (in the config dir, or a shipped name); saved to `target` (default:
        itself)."""
        path, text = files.read_source(name)
        data = parse_yaml(text, str(path))
        return cls(kind or detect_kind(path, data), target or path, files, data)

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
        self.saved = None

    def unset(self, path: str) -> None:
        """Remove the field at `path`, so the schema's default applies again."""
        *parents, last = path.split(".")
        node: Any = self.data
        for key in parents:
            node = node.get(key) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(last, None)
        self.saved = None

    def yaml_text(self) -> str:
        return yaml.safe_dump(copy.deepcopy(self.data), sort_keys=False)

    def validate(self) -> list[FieldError]:
        """[] when the file is valid; else where it is not, by field path."""
        return self._checked(save=False)

    def save(self) -> list[FieldError]:
        """Write the file if it is valid ([]); otherwise leave it untouched and say why."""
        return self._checked(save=True)

    def status(self) -> tuple[str, bool]:
        """The editor's status line for the draft as it is now, and whether it is good news.

        Said from the current edit and check, never kept from an earlier one: after a refused
        save, a field set right again must not leave "not saved: <old error>" standing."""
        if self.errors:
            verb = "not saved" if self.saved is False else "not valid"
            return f"{verb}: {self.errors[0]}", False
        if self.saved:
            return f"saved {self.files.shown(self.target)}", True
        return "valid, not saved yet", True

    def _checked(self, save: bool) -> list[FieldError]:
        try:
            with self.files.scratch(self.target, self.yaml_text()) as scratch:
                errors = self._check(scratch.path)
                if save and not errors:
                    scratch.commit()
        except ConfigError as exc:  # the target itself: outside, through a symlink, …
            errors = [FieldError("", str(exc))]
        self.errors = errors
        if save:
            self.saved = not errors
        return errors

    def _check(self, scratch: Path) -> list[FieldError]:
        try:
            validate_file(str(scratch), self.kind)
        except ConfigError as exc:
            if Path(exc.source) != scratch and not self.files.holds(Path(exc.source)):
                return [FieldError("", f"{exc.source}: {OUTSIDE_NOT_SHOWN}")]
            return [field_error(exc, self._paths)]
        return []
