"""The README's pictures are the ones `tools/docs_images.py` writes, and they are sound PNGs.

Cheap: nothing is drawn here. The README's section "What a participant sees" must show
exactly the files the script's shots write, no more and no fewer, and `docs/images/` must
hold those files and nothing else. Each file is checked as PNG by its own structure (the
8-byte signature, an IHDR chunk first, every chunk's CRC-32 over its type and data, an IEND
chunk last: PNG specification, sections 5.2-5.6), its pixel size read from IHDR. The sizes
stated for the README: 960 x 540 for one display, and the three-display rig as three
640 x 360 displays side by side, 1920 x 360. All of them together stay under 3 MB so the
repository does not grow heavy with pictures.

Redraw them with `python tools/docs_images.py` after a renderer change
(`python tools/docs_images.py --check` says whether they moved).
"""

from __future__ import annotations

import importlib.util
import re
import struct
import sys
import zlib
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
SECTION = "## What a participant sees"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
ONE_DISPLAY = (960, 540)
THREE_DISPLAYS = (3 * 640, 360)
TOTAL_LIMIT = 3 * 1024 * 1024  # [bytes]


def script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("docs_images", ROOT / "tools/docs_images.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def readme_images() -> list[str]:
    """The docs/images files the README's section links, in order."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert SECTION in text, f"README.md has no section {SECTION!r}"
    section = text.split(SECTION, 1)[1].split("\n## ", 1)[0]
    return re.findall(r"!\[[^\]]*\]\(docs/images/([^)\s]+)\)", section)


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG whose every chunk is whole and matches its CRC."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path.name}: not a PNG signature"
    at, types, size = 8, [], (0, 0)
    while at < len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        (crc,) = struct.unpack(">I", data[at + 8 + length : at + 12 + length])
        assert len(body) == length, f"{path.name}: chunk {kind!r} cut short"
        assert zlib.crc32(kind + body) == crc, f"{path.name}: chunk {kind!r} fails its CRC"
        if kind == b"IHDR":
            size = struct.unpack(">II", body[:8])
        types.append(kind)
        at += 12 + length
    assert types[0] == b"IHDR" and types[-1] == b"IEND" and b"IDAT" in types, types
    return size


def test_the_readme_shows_exactly_what_the_script_writes() -> None:
    written = [shot.file for shot in script().SHOTS]
    shown = readme_images()
    assert sorted(shown) == sorted(written), (shown, written)
    assert len(set(shown)) == len(shown), f"a picture shown twice: {shown}"
    on_disk = sorted(p.name for p in IMAGES.glob("*"))
    assert on_disk == sorted(written), f"docs/images holds {on_disk}, the script writes {written}"


def test_every_picture_is_a_whole_png_of_its_stated_size() -> None:
    shots = script().SHOTS
    for shot in shots:
        stated = THREE_DISPLAYS if shot.displays == 3 else ONE_DISPLAY
        assert shot.image_size == stated, (shot.name, shot.image_size)
        assert png_size(IMAGES / shot.file) == stated, shot.file
    total = sum((IMAGES / shot.file).stat().st_size for shot in shots)
    assert total < TOTAL_LIMIT, f"docs/images weighs {total} bytes"
