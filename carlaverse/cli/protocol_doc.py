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
import typing
from collections.abc import Callable, Iterable

import msgspec

from carlaverse import messages as m
from carlaverse.authority.service import TickSummary
from carlaverse.body.kinematics import JOINTS, LIMBS
from carlaverse.cli import wire_catalog as wc
from carlaverse.cli.exit_codes import MEANING, Exit
from carlaverse.node_runtime import NodeSummary
from carlaverse.traffic.scenario import CollisionSpec
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


def versions_region() -> str:
    """The versions a peer must match, read from the code and the installed metadata."""
    zenoh = next((r for r in _requirements() if r.startswith("eclipse-zenoh")), "eclipse-zenoh")
    carried = ", ".join(f"`{c.__name__}.schema`" for c in wc.message_structs()
                        if "schema" in _field_names(c))  # fmt: skip
    rows = [
        ["schema version", f"`SCHEMA_VERSION = {m.SCHEMA_VERSION}`", carried],
        ["pose layout version", f"`POSE_LAYOUT_VERSION = {m.POSE_LAYOUT_VERSION}`",
         "byte 0 of every pose (and of every row of a pose digest)"],
        ["Zenoh", f"`{zenoh}`", "the transport"],
        ["MessagePack", "any spec-compliant library (the project uses msgspec)",
         "every payload but the pose"],
    ]  # fmt: skip
    return _table(["what", "value", "where it travels"], rows)


def _field_names(cls: type[msgspec.Struct]) -> set[str]:
    return {f.name for f in msgspec.structs.fields(cls)}


def _requirements() -> list[str]:
    from importlib.metadata import PackageNotFoundError, requires

    try:
        return [r.replace(" ", "") for r in requires("carlaverse") or []]
    except PackageNotFoundError:  # a source tree that was never installed
        return []


def events_region() -> str:
    """The tagged union on `world/events`: each `type` and the message it announces."""
    rows = [[f"`{msgspec.inspect.type_info(c).tag}`", f"`{c.__name__}`",  # type: ignore[attr-defined]
             (c.__doc__ or "").strip().splitlines()[0] if c.__doc__ else ""]
            for c in typing.get_args(m.WorldEvent)]  # fmt: skip
    return _table(["`type`", "message", "what it says"], rows)


def joints_region() -> str:
    """`Skeleton.joints`: the names a walk node sends, in its order, and each joint's angles."""
    hinge = {limb[1]: limb[5] for limb in LIMBS}
    rows = []
    for joint in JOINTS:
        if joint == "neck":
            rows.append([f"`{joint}`", "spherical", "the head frame relative to the body frame"])
        elif joint in hinge:
            bend = "forward" if hinge[joint] < 0 else "backward"
            sign = "−" if hinge[joint] < 0 else "+"
            rows.append([f"`{joint}`", "hinge", f"pitch = {sign}bend angle (bends {bend}); "
                                                "roll = yaw = 0"])  # fmt: skip
        else:
            rows.append([f"`{joint}`", "spherical", "takes the hanging rest segment onto the "
                                                    "upper segment"])  # fmt: skip
    return _table(["joint", "kind", "angles (roll, pitch, yaw) [rad]"], rows)


def actor_defaults_region() -> str:
    """Per actor kind: the extent assumed when an actor's own is not known, and the
    collision defaults a scenario starts from (`collisions.actors`)."""
    physics = CollisionSpec().actors
    rows = []
    for kind in m.ACTOR_KINDS:
        e, p = m.KIND_EXTENTS[kind], physics[kind]
        rows.append([f"`{kind}`", f"{e.length:g} × {e.width:g} × {e.height:g}",
                     f"{p.mass_kg:g}", f"{p.restitution:g}"])  # fmt: skip
    return _table(["actor kind", "extent length × width × height [m]", "mass [kg]",
                   "restitution"], rows)  # fmt: skip


def stamped_region() -> str:
    """Which keys carry the authority's session time, and in which field."""
    rows = []
    for k in wc.key_docs():
        if not k.writer.startswith("authority"):
            continue
        stamped = [n for n in (p.strip() for p in k.payload.split(",") if p.strip())
                   if "t" in _field_names(getattr(m, n))]  # fmt: skip
        if stamped:
            rows.append([f"`{k.key}`", ", ".join(f"`{n}.t`" for n in stamped)])
    return _table(["key", "the authority's session time at sending"], rows)


def _span(offset: int, size: int) -> str:
    return str(offset) if size == 1 else f"{offset}–{offset + size - 1}"


REGIONS: dict[str, Callable[[], str]] = {
    "versions": versions_region,
    "keys": keys_region,
    "stamped-keys": stamped_region,
    "pose": pose_region,
    "npc-row": npc_region,
    "light-bits": lights_region,
    "audio-drive": audio_region,
    "events": events_region,
    "skeleton-joints": joints_region,
    "actor-defaults": actor_defaults_region,
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
