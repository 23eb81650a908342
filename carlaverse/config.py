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
from typing import Any, TypeVar, dataclass_transform

import msgspec
import yaml

from carlaverse.patterns import readable

T = TypeVar("T")

SHIPPED_PACKAGES = ("carlaverse.configs", "carlaverse.scenarios")

# msgspec's message: "Expected `float` <= 40.0 - at `$.road.grade_percent`"
AT_PATH = re.compile(r"^(?P<message>.*) - at `\$\.?(?P<path>[^`]*)`$", re.DOTALL)


class ConfigError(ValueError):
    """A configuration file is missing, unreadable or does not match its schema.

    Said as `SOURCE: message`, or `SOURCE:LINE:COLUMN: message` (1-based, as compilers and
    editors write it, so a terminal or an editor jumps there) when the place is known.
    """

    def __init__(
        self, source: str, message: str, line: int | None = None, column: int | None = None
    ) -> None:
        where = source if line is None else f"{source}:{line}:{column or 1}"
        super().__init__(f"{where}: {message}")
        self.source = source
        self.detail = message
        self.line = line
        self.column = column


def invalid_at(message: str) -> tuple[str, str]:
    """(dotted field path, what is wrong there) of a msgspec validation message; the path is
    "" when the message names no field."""
    match = AT_PATH.match(message)
    return (match["path"], match["message"]) if match else ("", message)


# msgspec hands `frozen` down to subclasses, but a type checker reads a subclass that does not
# repeat `frozen=True` as a mutable dataclass under a frozen one (msgspec issue 657): saying
# here that StrictStruct's subclasses default to frozen lets every config type stay
# `class X(StrictStruct):`. (`kw_only` is not handed down: it covers the fields of the class
# that sets it, and StrictStruct has none, so subclasses take positional arguments too.)
@dataclass_transform(frozen_default=True, field_specifiers=(msgspec.field,))
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
    """Parse YAML text; a syntax error is one line, `SOURCE:LINE:COLUMN: invalid YAML: ...`
    (PyYAML's own message spreads the problem and its context over six lines)."""
    try:
        return yaml.safe_load(text) or {}
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, column = (mark.line + 1, mark.column + 1) if mark else (None, None)
        raise ConfigError(source, f"invalid YAML: {_yaml_problem(exc)}", line, column) from exc
    except yaml.YAMLError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ConfigError(source, f"invalid YAML: {first}") from exc


def _yaml_problem(exc: yaml.MarkedYAMLError) -> str:
    """`problem, context at LINE:COLUMN`: what is wrong, then what the parser was inside."""
    problem = exc.problem or exc.context or "syntax error"
    if exc.problem and exc.context:
        mark, there = exc.context_mark, exc.problem_mark
        elsewhere = mark is not None and (there is None or mark.index != there.index)
        at = f" at {mark.line + 1}:{mark.column + 1}" if mark is not None and elsewhere else ""
        problem += f", {exc.context}{at}"
    return " ".join(problem.split())  # PyYAML wraps some messages over lines


def convert(data: Any, type_: type[T], source: str) -> T:
    """Turn parsed YAML into `type_`, raising ConfigError that names the field path."""
    try:
        return msgspec.convert(data, type_, strict=False)
    except msgspec.ValidationError as exc:
        raise ConfigError(source, readable(str(exc))) from exc


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
