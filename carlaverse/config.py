"""YAML configuration decoded into strict msgspec Structs.

One YAML file per node is the single source of truth (docs/architecture.md §10). Every config
type is a frozen Struct with `forbid_unknown_fields=True`, so a typo is an error rather than a
silently ignored key, and the error names the file, the field path and what was expected:

    configs/drive-desktop.yaml: Expected `float` >= 0 - at `$.ffb.spring.stiffness`

Paths given to `resolve_path` may be absolute, relative to the referring file (or the working
directory), or the name of a file shipped in `configs/` or `scenarios/`.
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import msgspec
import yaml

T = TypeVar("T")

SHIPPED_PACKAGES = ("carlaverse.configs", "carlaverse.scenarios")

# msgspec's message: "Expected `float` <= 40.0 - at `$.road.grade_percent`"
AT_PATH = re.compile(r"^(?P<message>.*) - at `\$\.?(?P<path>[^`]*)`$", re.DOTALL)


class ConfigError(ValueError):
    """A configuration file is missing, unreadable or does not match its schema."""

    def __init__(self, source: str, message: str) -> None:
        super().__init__(f"{source}: {message}")
        self.source = source
        self.detail = message


def invalid_at(message: str) -> tuple[str, str]:
    """(dotted field path, what is wrong there) of a msgspec validation message; the path is
    "" when the message names no field."""
    match = AT_PATH.match(message)
    return (match["path"], match["message"]) if match else ("", message)


class StrictStruct(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base for config types: immutable, keyword-only, unknown fields rejected."""


def shipped_dir(package: str = "carlaverse.configs") -> Path:
    """The directory of a shipped data package (`configs/` or `scenarios/`)."""
    return Path(str(resources.files(package)))


def resolve_path(name: str | Path, relative_to: Path | None = None) -> Path:
    """Find a config file: absolute, relative to `relative_to` or cwd, or shipped by name.

    A shipped file may be named with or without its `.yaml` suffix (`drive-desktop`).
    """
    candidate = Path(name).expanduser()
    if candidate.is_absolute():
        if candidate.is_file():
            return candidate
        raise ConfigError(str(candidate), "no such file")
    bases = [relative_to] if relative_to is not None else []
    bases.append(Path.cwd())
    for base in bases:
        if (base / candidate).is_file():
            return (base / candidate).resolve()
    for package in SHIPPED_PACKAGES:
        root = shipped_dir(package)
        for option in (candidate, candidate.with_name(candidate.name + ".yaml")):
            if (root / option).is_file():
                return root / option
    searched = ", ".join(str(b) for b in bases) + ", shipped configs/ and scenarios/"
    raise ConfigError(str(name), f"no such file (looked in {searched})")


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML text, naming the source and line on a syntax error."""
    try:
        return yaml.safe_load(text) or {}
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(source, f"invalid YAML{where}: {exc}") from exc


def convert(data: Any, type_: type[T], source: str) -> T:
    """Turn parsed YAML into `type_`, raising ConfigError that names the field path."""
    try:
        return msgspec.convert(data, type_, strict=False)
    except msgspec.ValidationError as exc:
        raise ConfigError(source, str(exc)) from exc


def load_config(path: str | Path, type_: type[T], relative_to: Path | None = None) -> T:
    """Load and validate one YAML file into `type_`."""
    resolved = resolve_path(path, relative_to)
    text = read_text(resolved)
    return convert(parse_yaml(text, str(resolved)), type_, str(resolved))


def read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(str(path), f"cannot read: {exc.strerror}") from exc


def to_yaml(value: msgspec.Struct) -> str:
    """The effective config as YAML, for archiving with a recording."""
    return yaml.safe_dump(msgspec.to_builtins(value), sort_keys=False)
