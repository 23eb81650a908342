"""References into docs/architecture.md point at sections that exist; none point outside."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ARCHITECTURE = ROOT / "docs" / "architecture.md"
REFERENCE = re.compile(r"architecture\.md((?:,? §\d+)+)")


def tracked_text_files() -> list[Path]:
    listed = subprocess.run(
        ["git", "ls-files", "*.py", "*.md", "*.toml", "*.yaml", "*.json5"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout.split()  # fmt: skip
    return [ROOT / name for name in listed if (ROOT / name).is_file()]


def section_numbers() -> set[int]:
    return {int(n) for n in re.findall(r"^## (\d+)\. ", ARCHITECTURE.read_text(), re.MULTILINE)}


def test_every_section_reference_names_an_existing_section() -> None:
    sections = section_numbers()
    assert sections == set(range(1, len(sections) + 1)), "sections are numbered 1..N"
    dangling = [
        f"{path.relative_to(ROOT)}: §{n}"
        for path in tracked_text_files()
        for match in REFERENCE.finditer(path.read_text(errors="replace"))
        for n in re.findall(r"\d+", match[1])
        if int(n) not in sections
    ]
    assert dangling == []


def test_nothing_refers_to_the_design_file_outside_the_repository() -> None:
    stale = [
        str(path.relative_to(ROOT))
        for path in tracked_text_files()
        if path.name != Path(__file__).name
        and re.search(r"DESIGN §|\.\./shared/", path.read_text(errors="replace"))
    ]
    assert stale == []
