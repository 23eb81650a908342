"""A config schema as a tree for an editor, generated from its strict Struct type.

Every Struct field becomes a section (a nested Struct) or a leaf the page edits: a number with
its bounds, a choice from a Literal, a switch, a text, or — for lists, mappings, unions and
array-like Structs, which a form cannot show well — YAML text in one line. The tree carries no
validation of its own: values go to the strict decoder the nodes use (`config_draft`).
"""

from __future__ import annotations

from typing import Any, Literal

import msgspec
from msgspec import inspect as mi

LeafKind = Literal["number", "integer", "choice", "bool", "text", "yaml"]

# config kinds that are not node kinds: (module, Struct) of the type `config validate` uses
FILE_SCHEMAS = {
    "scenario": ("carlaverse.traffic.scenario", "ScenarioSpec"),
    "vehicle": ("carlaverse.physics.params", "VehicleParams"),
    "router": ("carlaverse.config_check", "RouterConfig"),
    "rig": ("carlaverse.render.rig", "RenderConfig"),
}


class Leaf(msgspec.Struct, frozen=True):
    path: str  # dotted, as errors name it: `road.grade_percent`
    name: str
    kind: LeafKind
    default: Any = None  # as YAML would write it; None when the field is required
    required: bool = False
    choices: tuple[Any, ...] = ()
    bounds: str = ""  # `> 0`, `>= -40, <= 40`: what the decoder will demand


class Section(msgspec.Struct, frozen=True):
    path: str  # "" for the file's top level
    name: str
    leaves: tuple[Leaf, ...]
    sections: tuple[Section, ...]

    def walk(self) -> list[Section]:
        """This section and every one below it, depth first."""
        found = [self]
        for child in self.sections:
            found.extend(child.walk())
        return found

    def leaf(self, path: str) -> Leaf | None:
        for section in self.walk():
            for leaf in section.leaves:
                if leaf.path == path:
                    return leaf
        return None


def describe(config_type: type, name: str = "") -> Section:
    """The editing tree of `config_type` (a StrictStruct)."""
    info = mi.type_info(config_type)
    if not isinstance(info, mi.StructType):
        raise TypeError(f"{config_type!r} is not a Struct type")
    return _section(info, "", name or config_type.__name__)


def _section(info: mi.StructType, path: str, name: str) -> Section:
    leaves, sections = [], []
    for field in info.fields:
        field_path = f"{path}.{field.encode_name}" if path else field.encode_name
        if isinstance(field.type, mi.StructType) and not field.type.array_like:
            sections.append(_section(field.type, field_path, field.encode_name))
        else:
            leaves.append(_leaf(field, field_path))
    return Section(path, name, tuple(leaves), tuple(sections))


def _leaf(field: mi.Field, path: str) -> Leaf:
    kind, choices, bounds = _kind(field.type)
    return Leaf(
        path,
        field.encode_name,
        kind,
        default=_default(field),
        required=field.required,
        choices=choices,
        bounds=bounds,
    )


def _kind(t: mi.Type) -> tuple[LeafKind, tuple[Any, ...], str]:
    if isinstance(t, mi.BoolType):
        return "bool", (), ""
    if isinstance(t, mi.FloatType):
        return "number", (), _bounds(t)
    if isinstance(t, mi.IntType):
        return "integer", (), _bounds(t)
    if isinstance(t, mi.LiteralType):
        return "choice", tuple(t.values), ""
    if isinstance(t, mi.StrType):
        return "text", (), ""
    return "yaml", (), ""


def _bounds(t: mi.FloatType | mi.IntType) -> str:
    limits = ((">", t.gt), (">=", t.ge), ("<", t.lt), ("<=", t.le))
    # msgspec's own finite-float guard (±1e15) says nothing a person needs to read
    return ", ".join(f"{op} {v:g}" for op, v in limits if v is not None and abs(v) < 1e15)


def _default(field: mi.Field) -> Any:
    if field.default is not msgspec.NODEFAULT:
        return msgspec.to_builtins(field.default)
    if field.default_factory is not msgspec.NODEFAULT:
        return msgspec.to_builtins(field.default_factory())
    return None
