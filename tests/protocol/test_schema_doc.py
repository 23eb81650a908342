"""docs/protocol.md and `carlaverse schema` agree with the message Structs and the codecs."""

from __future__ import annotations

import base64
import json
import re
import struct
from pathlib import Path

import jsonschema
import msgpack
import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.cli import protocol_doc as doc
from carlaverse.cli import wire_catalog as wc
from carlaverse.cli.schema import json_schema
from carlaverse.keys import Keys, parse

DOC = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"


def test_generated_regions_of_protocol_md_match_the_structs() -> None:
    text = DOC.read_text(encoding="utf-8")
    fresh = doc.rewrite(text)
    if fresh != text:
        regions = re.findall(r"BEGIN GENERATED ([\w-]+) .*?-->\n(.*?)<!-- END", text, re.S)
        changed = [name for name, body in regions if body != doc.REGIONS[name]()]
        pytest.fail(
            f"docs/protocol.md is out of date in region(s) {changed}: "
            f"run `{doc.REGENERATE}` and commit the result"
        )


def test_a_doc_without_a_region_is_refused_with_the_command_that_fixes_it() -> None:
    with pytest.raises(doc.RegionError, match=r"missing.*'keys'.*BEGIN GENERATED"):
        doc.rewrite("# nothing generated here\n")


def test_write_doc_regenerates_a_stale_copy(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    stale = tmp_path / "protocol.md"
    stale.write_text(re.sub(r"\| `seq` \|", "| `sequence` |", DOC.read_text(encoding="utf-8")))
    assert main(["schema", "--write-doc", str(stale)]) == 0
    assert stale.read_text(encoding="utf-8") == DOC.read_text(encoding="utf-8")
    assert "regenerated" in capsys.readouterr().err


def test_the_pose_table_is_where_encode_pose_puts_each_value() -> None:
    pose = m.Pose(7, 1234.5, 1.25, -2.5, 3.0, 0.125, -0.25, 0.5, 4.0, 5.0, 6.0,
                  0.5, 0.25, -0.75, 1.5, -2.0, 8.0, flags=m.POSE_FLAG_TELEPORT)  # fmt: skip
    raw = m.encode_pose(pose)
    codes = {"u8": "B", "u16": "H", "u32": "I", "f16": "e", "f32": "f", "f64": "d"}
    expected = {"version": m.POSE_LAYOUT_VERSION, "reserved": 0}
    layout = wc.pose_layout()
    assert sum(b.size for b in layout) == m.POSE_SIZE == len(raw) == 64
    for b in layout:
        (value,) = struct.unpack_from("<" + codes[b.type], raw, b.offset)
        assert value == expected.get(b.name, getattr(pose, b.name, None)), b.name


def test_the_npc_row_table_is_the_numpy_layout() -> None:
    row = np.zeros(1, dtype=m.NPC_DTYPE)
    row["yaw_rate"], row["kind"], row["lights"] = 0.5, 5, m.LIGHT_BRAKE | m.LIGHT_LOW_BEAM
    raw = row.tobytes()
    fields = {b.name: b for b in wc.npc_row_layout()}
    assert sum(b.size for b in fields.values()) == m.NPC_DTYPE.itemsize == 44
    assert struct.unpack_from("<f", raw, fields["yaw_rate"].offset) == (0.5,)
    assert raw[fields["kind"].offset] == 5
    assert struct.unpack_from("<H", raw, fields["lights"].offset) == (0x12,)
    assert struct.calcsize("<10fBBH") == 44  # the one-line struct the doc offers


def test_the_key_table_covers_every_key_the_key_space_builds() -> None:
    documented = {k.key for k in wc.key_docs()}
    assert documented == wc.key_space_paths()
    for key in documented:  # and every documented key is one `keys.parse` accepts
        concrete = key.replace("<id>", "n-1").replace("<tile>", "t0_-3")
        assert parse(f"{Keys('s').prefix}/{concrete}")


def test_field_types_and_requirements_are_msgspecs_own() -> None:
    join = {f.name: f for f in wc.fields(m.JoinRequest)}
    assert join["instance"].required and join["instance"].type.startswith("str")
    assert not join["config_yaml"].required and join["extent"].type == "Extent"
    reply = {f.name: f for f in wc.fields(m.JoinReply)}
    assert reply["spawn"].type == "SpawnPoint or nil" and reply["spawn"].default == "nil"
    # the generated requirement is the decoder's: leaving a required field out is rejected
    with pytest.raises(m.MessageError, match="instance"):
        m.JOIN_REQUEST.decode(msgpack.packb({"schema": 1, "node_id": "a", "kind": "x"}))


def _as_json(value: object) -> object:
    """A decoded MessagePack value as the JSON Schema sees it (bin -> base64)."""
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    if isinstance(value, dict):
        return {k: _as_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_as_json(v) for v in value]
    return value


EGO = m.EgoInfo("car-1", "drive", "car", m.Extent(), 1500.0, "lab", m.Pose(9, 10.0, 1.0, 2.0))
SAMPLES = [
    ("EgoState", m.EGO_STATE, m.EgoState(3, 10.0, lights=m.LIGHT_BRAKE, indicator="left")),
    ("NpcBatch", m.NPC_BATCH, m.NpcBatch.pack(4, 10.0, ["npc-1"], np.zeros(1, m.NPC_DTYPE))),
    ("LightsState", m.LIGHTS, m.LightsState(5, 10.0, [m.TrafficLight("j1", "rGy", 2, 3.5)])),
    ("Weather", m.WEATHER, m.Weather(6, 10.0, cloudiness=0.4)),
    ("WorldEvent", m.WORLD_EVENT, m.Despawned(7, 10.0, "car-1", "timeout")),
    ("WorldEvent", m.WORLD_EVENT, m.ContactStarted(8, 10.0, 1, "a", "b", 3.0)),
    ("JoinRequest", m.JOIN_REQUEST, m.JoinRequest(m.SCHEMA_VERSION, "car-1", "i", "drive")),
    ("JoinReply", m.JOIN_REPLY, m.JoinReply(m.SCHEMA_VERSION, True, spawn=m.SpawnPoint(1, 2))),
    ("ClockReply", m.CLOCK_REPLY, m.ClockReply(10.0, True)),
    ("Snapshot", m.SNAPSHOT, m.Snapshot(m.SCHEMA_VERSION, 10.0, [EGO])),
]


@pytest.mark.parametrize(("name", "codec", "message"), SAMPLES)
def test_the_json_schema_accepts_what_the_codecs_put_on_the_wire(name, codec, message) -> None:
    schema = json_schema()
    wire = msgpack.unpackb(codec.encode(message), raw=False)
    jsonschema.validate(_as_json(wire), {**schema, "$ref": f"#/$defs/{name}"})


def test_the_json_schema_rejects_a_message_missing_a_required_field() -> None:
    schema = {**json_schema(), "$ref": "#/$defs/JoinRequest"}
    with pytest.raises(jsonschema.ValidationError, match="instance"):
        jsonschema.validate({"schema": 1, "node_id": "a", "kind": "x"}, schema)


def test_schema_json_names_every_key_and_message(capsys: pytest.CaptureFixture) -> None:
    assert main(["schema", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["x-schema-version"] == m.SCHEMA_VERSION
    assert {s.__name__ for s in wc.message_structs()} | {"WorldEvent"} == set(printed["$defs"])
    keys = {k.removeprefix("carlaverse/{session}/") for k in printed["x-keys"]}
    assert keys == wc.key_space_paths()
    assert [b["size"] for b in printed["$defs"]["Pose"]["x-wire"]["layout"]][:4] == [1, 1, 2, 4]
