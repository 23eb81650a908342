"""The shape of the `carlaverse.messages` package (issue 41): every message type is defined in
one of its modules and reachable from the package itself, the modules import only those listed
before them, and the package lists its Structs family by family, each in its module's order
(the order `carlaverse schema` and docs/protocol.md present them in)."""

from __future__ import annotations

import ast
import importlib
import inspect
import pickle
import re
from pathlib import Path
from types import ModuleType

import msgspec

from carlaverse import messages as m
from carlaverse.cli import wire_catalog as wc

PACKAGE = Path(m.__file__).parent


def listed_modules() -> list[str]:
    """The modules the package docstring lists, in its order: `    pose        the 64-byte ...`."""
    return re.findall(r"^    (\w+) {2,}\S", m.__doc__ or "", re.MULTILINE)


def submodule(name: str) -> ModuleType:
    return importlib.import_module(f"{m.__name__}.{name}")


def public_names(module: ModuleType) -> list[str]:
    """Names a module defines itself (not those it imports), the type variable aside."""
    tree = ast.parse(Path(module.__file__ or "").read_text(encoding="utf-8"))
    names: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.ClassDef | ast.FunctionDef):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return [n for n in names if not n.startswith("_") and n != "T"]


def test_the_docstring_lists_every_module_of_the_package() -> None:
    files = {p.stem for p in PACKAGE.glob("*.py")} - {"__init__"}
    assert sorted(listed_modules()) == sorted(files)


def test_every_public_name_of_every_module_is_the_packages_own() -> None:
    for name in listed_modules():
        module = submodule(name)
        for attr in public_names(module):
            assert getattr(m, attr) is getattr(module, attr), f"{name}.{attr}"
            assert attr in m.__all__, f"{name}.{attr} missing from __all__"


def test_each_module_imports_only_modules_listed_before_it() -> None:
    order = listed_modules()
    for position, name in enumerate(order):
        tree = ast.parse((PACKAGE / f"{name}.py").read_text(encoding="utf-8"))
        imported = {
            node.module.removeprefix(f"{m.__name__}.")
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(m.__name__)
        }
        assert imported <= set(order[:position]), f"{name} imports {imported}"


def test_every_struct_is_listed_family_by_family_in_source_order() -> None:
    """A Struct's place is (its module's place in the list, its line in that module); the
    schema and the doc must list them so, or a new Struct's import is in the wrong place."""
    order = listed_modules()
    defined = [
        cls
        for name in order
        for cls in vars(submodule(name)).values()
        if isinstance(cls, type)
        and issubclass(cls, msgspec.Struct)
        and cls.__module__ == f"{m.__name__}.{name}"
    ]

    def place(cls: type) -> tuple[int, int]:
        return order.index(cls.__module__.rsplit(".", 1)[1]), inspect.getsourcelines(cls)[1]

    assert wc.message_structs() == sorted(defined, key=place)
    assert len(defined) > 30  # the walk found the messages, not an empty list


def test_a_message_pickles_by_its_module_and_comes_back_equal() -> None:
    """Structs cross process boundaries pickled (the audio and SUMO pipes): the name pickle
    records must import back, and the message must compare equal."""
    pose = m.Pose(3, 12.5, 1.0, -2.0, yaw=0.5)
    brief = m.TrialBrief(schema=m.SCHEMA_VERSION, study="s1", participant="p01")
    for message in (pose, brief, m.Spawned(1, 2.0, "car-1", "drive", "car")):
        assert pickle.loads(pickle.dumps(message)) == message
