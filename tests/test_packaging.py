"""The explicit package list in pyproject.toml must match the tree (see its comment)."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_directory_is_listed() -> None:
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(conf["packages"])
    mapping = conf["package-dir"]
    found = set()
    for name, directory in mapping.items():
        base = ROOT / directory
        found.add(name)
        for init in base.rglob("__init__.py"):
            rel = init.parent.relative_to(base)
            if rel.parts:
                found.add(".".join((name, *rel.parts)))
    assert found - listed == set(), "add these to [tool.setuptools] packages"
    assert listed - found == set(), "listed packages with no directory"


def test_the_library_never_imports_a_node_kind_nor_ships_root_only_harnesses() -> None:
    library = ROOT / "carlaverse"
    offenders = [
        str(p.relative_to(ROOT))
        for p in library.rglob("*.py")
        if "carlaverse_nodes" in p.read_text(encoding="utf-8")
    ]
    assert offenders == [], "the library must not import node kinds (nodes/ = carlaverse_nodes)"
    testing = {p.name for p in (library / "testing").glob("*.py")}
    assert not testing & {"netns.py", "wan.py", "wan_probe.py"}, "test harnesses: tests/, tools/"
