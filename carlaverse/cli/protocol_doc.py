"""The generated regions of docs/protocol.md: field tables, byte layouts, the key table.

A region sits between two HTML comments, so the prose around it stays hand-written:

    <!-- BEGIN GENERATED messages (carlaverse schema --write-doc docs/protocol.md) -->
    ...
    <!-- END GENERATED messages -->

`rewrite(text)` returns the document with every region regenerated from the Structs; the
protocol test fails when that differs from the file, naming the command that fixes it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable

import msgspec

from carlaverse import messages as m
from carlaverse.authority.service import TickSummary
from carlaverse.cli import wire_catalog as wc
from carlaverse.cli.exit_codes import MEANING, Exit
from carlaverse.node_runtime import NodeSummary
from carlaverse.world.stream_summary import StreamSummary

REGENERATE = "carlaverse schema --write-doc docs/protocol.md"

_REGION = re.compile(
    r"(<!-- BEGIN GENERATED (?P<name>[\w-]+) \(.*?\) -->\n)"
    r"(?P<body>.*?)"
    r"(<!-- END GENERATED (?P=name) -->)",
    re.DOTALL,
)

# Units of the NPC row columns the pose does not share.
_NPC_NOTES = {
    "yaw_rate": "[rad/s]",
    "length": "[m] bounding box",
    "width": "[m]",
    "height": "[m]",
    "kind": "index into the actor kinds below",
    "reserved": "0",
    "lights": "light bits below (NPCs set blinkers, brake, low/high beam, fog, reverse)",
}


class RegionError(ValueError):
    """docs/protocol.md lacks a generated region or has one the generator does not know."""


def _table(header: Iterable[str], rows: Iterable[Iterable[object]]) -> str:
    head = list(header)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _cell(value: object) -> str:
    return str(value).replace("|", "\\|") if value != "" else ""


def struct_table(cls: type[msgspec.Struct]) -> str:
    """A message: its encoding, then a row per field (position matters for arrays)."""
    array = msgspec.inspect.type_info(cls).array_like  # type: ignore[attr-defined]
    header = ["#"] * array + ["field", "type", "required", "default", "notes"]
    rows = [
        [i] * array + [f"`{f.name}`", f.type, "yes" if f.required else "no", f.default, f.note]
        for i, f in enumerate(wc.fields(cls))
    ]
    return f"{_heading(cls, wc.encoding(cls))}\n\n{_table(header, rows)}"


def summary_table(cls: type[msgspec.Struct]) -> str:
    """A `--json` summary object: every field is always printed."""
    rows = [[f"`{f.name}`", f.type, f.note] for f in wc.fields(cls)]
    return f"{_heading(cls, 'A JSON object')}\n\n{_table(['key', 'type', 'notes'], rows)}"


def _heading(cls: type, encoding: str) -> str:
    doc = (cls.__doc__ or "").strip().splitlines()
    return f"#### `{cls.__name__}`\n\n{encoding}." + (f" {doc[0]}" if doc else "")


def messages_region() -> str:
    """The named constrained types, then every Struct; the pose only if some message carries
    it as MessagePack too."""
    structs = [c for c in wc.message_structs() if c is not m.Pose or wc.embedded(m.Pose)]
    tables = [struct_table(cls) for cls in structs]
    named = wc.constrained_types()
    if named:
        rows = [[f"`{name}`", wc.scalar_type(info)] for name, info in named]
        lead = "Named types used below; a value outside the range is rejected."
        tables.insert(0, f"#### Constrained types\n\n{lead}\n\n{_table(['type', 'is'], rows)}")
    return "\n".join(tables)


def outputs_region() -> str:
    """The `--json` summaries that are Structs: `join`, `stats` rows, `authority` tick."""
    summaries = (NodeSummary, StreamSummary, TickSummary)
    return "\n".join(summary_table(cls) for cls in summaries)


def exit_codes_region() -> str:
    """The one exit-code table of every command (carlaverse.cli.exit_codes)."""
    rows = [[int(code), f"`{code.name}`", MEANING[code]] for code in Exit]
    return _table(["code", "name", "meaning"], rows)


def keys_region() -> str:
    rows = [
        [f"`{k.key}`", k.writer, k.request and f"`{k.request}`", _names(k.payload), k.delivery]
        for k in wc.key_docs()
    ]
    return _table(["key (after `carlaverse/<session>/`)", "writer", "query payload",
                   "payload / reply", "delivery"], rows)  # fmt: skip


def _names(payload: str) -> str:
    return ", ".join(f"`{p.strip()}`" for p in payload.split(",")) if payload else "—"


def pose_region() -> str:
    notes = wc.field_notes(m.Pose)
    header_notes = {
        "version": f"layout version, = {m.POSE_LAYOUT_VERSION}",
        "flags": "pose flags below",
        "reserved": "0",
    }
    notes |= header_notes
    rows = [[_span(b.offset, b.size), b.type, f"`{b.name}`", notes.get(b.name, "")]
            for b in wc.pose_layout()]  # fmt: skip
    flags = _table(["bit", "flag"], [[hex(v), f"`{n}`"] for v, n in wc.pose_flags()])
    total = f"Total: {m.POSE_SIZE} bytes, little-endian, no padding.\n\n"
    return _table(["bytes", "type", "field", "notes"], rows) + "\n" + total + flags


def npc_region() -> str:
    notes = wc.field_notes(m.Pose) | _NPC_NOTES
    rows = [
        [_span(b.offset, b.size), b.type, f"`{b.name}`", notes.get(b.name, "")]
        for b in wc.npc_row_layout()
    ]
    size = f"Row size: {m.NPC_DTYPE.itemsize} bytes, little-endian, no padding.\n\n"
    kinds = _table(["kind", "actor kind"], [[i, f"`{k}`"] for i, k in enumerate(m.ACTOR_KINDS)])
    return _table(["bytes", "type", "field", "notes"], rows) + "\n" + size + kinds


def lights_region() -> str:
    return _table(["bit", "light"], [[f"{v} (`{hex(v)}`)", f"`{n}`"] for v, n in wc.light_bits()])


def audio_region() -> str:
    """Per emitter kind, what its two drive values mean; then the siren patterns."""
    rows = [[f"`{k}`", a, b] for k, (a, b) in m.AUDIO_DRIVE_MEANING.items()]
    patterns = _table(["`drive_a`", "siren pattern"], enumerate(m.SIREN_PATTERNS))
    return _table(["kind", "`drive_a`", "`drive_b`"], rows) + "\n" + patterns


def _span(offset: int, size: int) -> str:
    return str(offset) if size == 1 else f"{offset}–{offset + size - 1}"


REGIONS: dict[str, Callable[[], str]] = {
    "keys": keys_region,
    "pose": pose_region,
    "npc-row": npc_region,
    "light-bits": lights_region,
    "audio-drive": audio_region,
    "messages": messages_region,
    "outputs": outputs_region,
    "exit-codes": exit_codes_region,
}


def rewrite(text: str) -> str:
    """`text` with every generated region regenerated; raise RegionError if one is missing."""
    found = {match["name"] for match in _REGION.finditer(text)}
    missing, unknown = set(REGIONS) - found, found - set(REGIONS)
    if missing or unknown:
        raise RegionError(
            f"generated regions missing: {sorted(missing)}, unknown: {sorted(unknown)}; "
            f"add `<!-- BEGIN GENERATED NAME ({REGENERATE}) -->` … `<!-- END GENERATED NAME -->`"
        )
    return _REGION.sub(lambda match: match[1] + REGIONS[match["name"]]() + match[4], text)


def all_regions() -> str:
    """Every region with its markers, for `carlaverse schema --markdown`."""
    return "\n".join(
        f"<!-- BEGIN GENERATED {name} ({REGENERATE}) -->\n{make()}<!-- END GENERATED {name} -->\n"
        for name, make in REGIONS.items()
    )
