"""Writing a benchmark's section of docs/benchmarks.md, leaving the other sections intact."""

from __future__ import annotations

from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "benchmarks.md"


def write_section(title: str, body: str, command: str) -> None:
    """Replace the `## title` section (or append it) with the body and how to reproduce it."""
    text = DOC.read_text() if DOC.exists() else "# Benchmarks\n"
    header = f"## {title}"
    section = f"{header}\n\nReproduce: `{command.replace(' --write', '').strip()}`\n\n{body}\n"
    if header in text:
        start = text.index(header)
        end = text.find("\n## ", start + 1)
        text = text[:start] + section + (text[end + 1 :] if end >= 0 else "")
    else:
        text = text.rstrip() + "\n\n" + section
    DOC.parent.mkdir(exist_ok=True)
    DOC.write_text(text)
