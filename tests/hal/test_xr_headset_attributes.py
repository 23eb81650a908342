"""A headset backend never hides a method of XrHeadset behind an attribute of its own.

OpenXrHeadset once stored its OpenXR action handles as `self.actions`, which shadowed
`XrHeadset.actions()`: the walk node's `self.headset.actions()` then called a dict on every
tick, and only on a real headset (mypy's method-assign check found it). Backends are read from
their source, since opening the OpenXR one needs a runtime and a headset.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

from carlaverse.hal.xr import XrHeadset

XR_DIR = Path(inspect.getfile(XrHeadset)).parent
BACKENDS = sorted(p for p in XR_DIR.glob("*.py") if "XrHeadset)" in p.read_text())


def assigned_self_attributes(source: str) -> set[str]:
    """Names `x` of every `self.x = ...` (plain, annotated or augmented) in the source."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = [t for target in node.targets for t in ast.walk(target)]
        elif isinstance(node, ast.AnnAssign | ast.AugAssign):
            targets = [node.target]
        for target in targets:
            if (
                isinstance(target, ast.Attribute)
                and isinstance(target.value, ast.Name)
                and target.value.id == "self"
            ):
                names.add(target.attr)
    return names


def test_backends_are_found() -> None:
    assert {p.name for p in BACKENDS} >= {"openxr_headset.py", "sim.py", "mouse.py"}


@pytest.mark.parametrize("path", BACKENDS, ids=lambda p: p.name)
def test_no_attribute_shadows_a_headset_method(path: Path) -> None:
    methods = {name for name, value in inspect.getmembers(XrHeadset) if callable(value)}
    shadowing = assigned_self_attributes(path.read_text()) & methods
    assert not shadowing, f"{path.name} assigns self.{', self.'.join(sorted(shadowing))}"


def test_the_check_sees_the_old_shadowing() -> None:
    # The assignment OpenXrHeadset had: the check must name it.
    old = "class H:\n    def f(self):\n        self.actions = {}\n"
    assert "actions" in assigned_self_attributes(old)
