"""`carlaverse schema`: the wire contract, generated from the message Structs.

    carlaverse schema                      one line per key: payload type and encoding
    carlaverse schema --json               a JSON Schema (2020-12) of every message and key
    carlaverse schema --markdown           the generated regions of docs/protocol.md
    carlaverse schema --write-doc FILE     regenerate those regions in FILE in place

The JSON Schema describes the MessagePack values as JSON would show them: a `bin` field is a
base64 string there. The pose is not MessagePack; its schema carries the byte layout instead.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import msgspec

from carlaverse import messages as m
from carlaverse.cli import wire_catalog as wc
from carlaverse.cli.common import fail, json_stdout

JSON_SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"
REF = "#/$defs/{name}"
DESCRIPTION = (
    "Messages on carlaverse/<session>/... keys, MessagePack-encoded (docs/protocol.md). This "
    "schema shows the decoded values as JSON would: a MessagePack `bin` is a base64 string here. "
    "`x-encoding` says map or array; the pose is a fixed binary layout given in `x-wire`."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Print the wire contract generated from the message Structs (docs/protocol.md explains it)."
    )
    out = parser.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="JSON Schema of every message and key")
    out.add_argument("--markdown", action="store_true", help="generated tables of protocol.md")
    out.add_argument("--write-doc", metavar="FILE", help="regenerate the tables inside FILE")


def run(args: argparse.Namespace) -> int:
    if args.json:
        with json_stdout(True) as out:
            out.write(json.dumps(json_schema(), indent=2) + "\n")
    elif args.markdown:
        from carlaverse.cli.protocol_doc import all_regions

        sys.stdout.write(all_regions())
    elif args.write_doc:
        return _write_doc(Path(args.write_doc))
    else:
        _print_summary()
    return 0


def _write_doc(path: Path) -> int:
    from carlaverse.cli.protocol_doc import RegionError, rewrite

    try:
        text = path.read_text(encoding="utf-8")
        new = rewrite(text)
    except (OSError, RegionError) as exc:
        return fail("schema", f"{path}: {exc}")
    if new != text:
        path.write_text(new, encoding="utf-8")
    print(f"{path}: {'regenerated' if new != text else 'already up to date'}", file=sys.stderr)
    return 0


def _print_summary() -> None:
    print(f"schema version {m.SCHEMA_VERSION}; keys under carlaverse/<session>/")
    for k in wc.key_docs():
        request = f" (query payload: {k.request})" if k.request else ""
        print(f"{k.key:<22} {k.payload or '-'}{request}")


# --------------------------------------------------------------------------- JSON Schema


def json_schema() -> dict[str, Any]:
    """Every message as a JSON Schema component, plus which key carries which component."""
    structs = wc.message_structs()
    _, defs = msgspec.json.schema_components(structs, ref_template=REF)
    for cls in structs:
        _annotate(defs[cls.__name__], cls)
    defs["WorldEvent"] = {
        "title": "WorldEvent",
        "description": "One of the events on world/events, told apart by its `type` field.",
        "oneOf": [{"$ref": REF.format(name=c.__name__)} for c in wc.world_event_types()],
    }
    defs["Pose"]["x-wire"] = _pose_wire()
    return {
        "$schema": JSON_SCHEMA_DIALECT,
        "title": "CARLAverse wire messages",
        "description": DESCRIPTION,
        "x-schema-version": m.SCHEMA_VERSION,
        "x-keys": {f"carlaverse/{{session}}/{k.key}": _key_entry(k) for k in wc.key_docs()},
        "$defs": defs,
    }


def _annotate(schema: dict[str, Any], cls: type[msgspec.Struct]) -> None:
    """Add each field's unit/meaning and the wire encoding to msgspec's schema of `cls`."""
    schema["x-encoding"] = wc.encoding(cls)
    docs = wc.fields(cls)  # by wire name, in field order
    if "properties" in schema:
        for doc in docs:
            if doc.note:
                schema["properties"][doc.name]["description"] = doc.note
    elif "prefixItems" in schema:
        for doc, item in zip(docs, schema["prefixItems"], strict=True):
            item["title"] = doc.name
            if doc.note:
                item["description"] = doc.note


def _pose_wire() -> dict[str, Any]:
    return {
        "size": m.POSE_SIZE,
        "byte_order": "little-endian",
        "layout": [msgspec.to_builtins(b) for b in wc.pose_layout()],
        "flags": {name: bit for bit, name in wc.pose_flags()},
    }


def _key_entry(k: wc.KeyDoc) -> dict[str, Any]:
    entry: dict[str, Any] = {"writer": k.writer, "delivery": k.delivery}
    if k.payload:
        names = [n.strip() for n in k.payload.split(",")]
        entry["payload"] = {"$ref": REF.format(name=names[0] if len(names) == 1 else "WorldEvent")}
    if k.request:
        entry["request"] = (
            {"$ref": REF.format(name=k.request)} if k.request != "empty" else "empty payload"
        )
    return entry


def main(argv: list[str] | None = None) -> int:
    """`python -m carlaverse.cli.schema ...`, the same as `carlaverse schema ...`."""
    from carlaverse.cli import main as cli_main

    return cli_main(["schema", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
