"""docs/benchmarks.md holds only figures its scripts wrote (tools/bench/benchdoc.py).

Each `## ` section must be one generated region (between benchdoc's markers) that starts with
the command regenerating it; outside the regions no digit may appear, so a figure typed by
hand, or left behind by an edit, fails here. The scripts themselves must detect the machine
and the versions at run time rather than spell them.
"""

from __future__ import annotations

import importlib.util
import re
import shlex
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "tools" / "bench"
DOC = ROOT / "docs" / "benchmarks.md"
# What a hand-typed machine description looks like in a script's prose.
HAND_TYPED = re.compile(
    r"CPython \d|x86_64|aarch64|\b\d+ (shared )?cores\b|"
    r"\b(zenoh|mcap|rerun-sdk|msgspec|SUMO|libsumo|numpy) \d+\.\d+"
)


def load_benchdoc() -> ModuleType:
    spec = importlib.util.spec_from_file_location("benchdoc", BENCH / "benchdoc.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while decorating
    spec.loader.exec_module(module)
    return module


def sections(text: str) -> dict[str, str]:
    """`## title` -> the section's text after its heading line."""
    parts = re.split(r"^## (.+)$", text, flags=re.MULTILINE)
    return {title.strip(): body for title, body in zip(parts[1::2], parts[2::2], strict=True)}


def problems(text: str, benchdoc: ModuleType, skip: frozenset[str] = frozenset()) -> list[str]:
    """Everything wrong with a benchmarks document, one line each; empty when it is sound."""
    found = []
    begin, end = re.escape(benchdoc.BEGIN), re.escape(benchdoc.END)
    region = re.compile(rf"{begin}\n(.*?)\n{end}", re.DOTALL)
    text = without_sections(text, skip)
    for title, body in sections(text).items():
        regions = region.findall(body)
        if len(regions) != 1:
            found.append(f"section {title!r}: {len(regions)} generated regions, expected 1")
            continue
        found += [f"section {title!r}: {p}" for p in reproduce_problems(regions[0], benchdoc)]
    outside = region.sub("", text)
    for line in outside.splitlines():
        if re.search(r"\d", line) and not line.startswith("## "):
            found.append(f"figure outside a generated region: {line[:80]!r}")
    for title in sections(text):
        if re.search(r"\d", title):
            found.append(f"figure in a heading: {title!r}")
    return found


def without_sections(text: str, titles: frozenset[str]) -> str:
    for title in titles:
        text = re.sub(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", "", text, flags=re.M | re.S)
    return text


def hand_typed(scripts: list[Path]) -> list[str]:
    return [
        f"{script.name}:{n}: {line.strip()}"
        for script in scripts
        for n, line in enumerate(script.read_text().splitlines(), 1)
        if HAND_TYPED.search(line)
    ]


def reproduce_problems(generated: str, benchdoc: ModuleType) -> list[str]:
    first = generated.splitlines()[0]
    match = re.fullmatch(re.escape(benchdoc.REPRODUCE) + r"`([^`]+)`", first)
    if not match:
        return [f"does not start with a reproduce command: {first[:80]!r}"]
    words = shlex.split(match[1])
    scripts = [w for w in words if w.startswith("tools/bench/") and w.endswith(".py")]
    out = []
    if len(scripts) != 1 or not (ROOT / scripts[0]).is_file():
        out.append(f"reproduce command names no script in tools/bench: {match[1]!r}")
    if "--write" not in words:
        out.append(f"reproduce command would not rewrite the section: {match[1]!r}")
    if "Machine: " not in generated:
        out.append("no machine description")
    return out


def test_every_section_is_generated_and_regenerable() -> None:
    assert problems(DOC.read_text(), load_benchdoc(), frozenset()) == []


def test_benchmark_scripts_detect_the_machine_rather_than_spell_it() -> None:
    scripts = [s for s in sorted(BENCH.glob("*.py"))]
    assert hand_typed(scripts) == []


def test_a_hand_typed_figure_or_a_missing_command_is_caught() -> None:
    benchdoc = load_benchdoc()
    good = "# Benchmarks\n\n" + benchdoc.render_section(
        "Example", "| n |\n|---|\n| 42 |", "python tools/bench/benchdoc.py"
    )
    assert problems(good, benchdoc) == []
    assert problems(good + "\nMeasured again later: 17 ms.\n", benchdoc)
    assert problems(good.replace(benchdoc.REPRODUCE, "Run: "), benchdoc)
    assert problems(good + "\n## Typed by hand\n\nAll good.\n", benchdoc)


def test_write_section_replaces_one_section_and_keeps_the_rest(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    benchdoc = load_benchdoc()
    monkeypatch.setattr(benchdoc, "DOC", tmp_path / "benchmarks.md")
    command = "python tools/bench/benchdoc.py"
    benchdoc.write_section("First", "first body 1", command)
    benchdoc.write_section("Second", "second body 2", command, benchdoc.RunInfo.start())
    benchdoc.write_section("First", "first body 3", command)
    text = benchdoc.DOC.read_text()
    assert list(sections(text)) == ["First", "Second"]
    assert "first body 3" in text and "first body 1" not in text and "second body 2" in text
    assert f"`{command} --write`" in text
    assert problems(text, benchdoc) == []
