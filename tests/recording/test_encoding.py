"""The JSON envelope: readable views, JSON Schemas from the Structs, raw payloads kept."""

from __future__ import annotations

import json

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.encoding import KeyFormat, payload_of, to_view

KEYS = Keys("enc")
EVERY_KEY = [
    KEYS.pose("a", "t0_0"), KEYS.state("a"), KEYS.override("a"), KEYS.ego("a", "skeleton"),
    KEYS.world("npc"), KEYS.world("lights"), KEYS.world("weather"), KEYS.world("events"),
    KEYS.impulse("a"), KEYS.authority("map"), KEYS.authority("snapshot"),
    KEYS.authority("configs"), KEYS.authority("scenario"), KEYS.node("a"),
    "carlaverse/enc/not/a/known/key",
]  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(key=st.sampled_from(EVERY_KEY), payload=st.binary(max_size=300))
def test_any_payload_on_any_key_is_recorded_and_comes_back_intact(key: str, payload: bytes) -> None:
    encoded = KeyFormat(key).encode(payload)
    assert payload_of(encoded.data) == (payload, "put")
    doc = json.loads(encoded.data)
    assert set(doc) <= {"raw", "msg", "error"}


def test_every_schema_is_self_contained_json_schema() -> None:
    for key in EVERY_KEY:
        fmt = KeyFormat(key)
        schema = json.loads(fmt.schema_bytes())
        assert schema["type"] == "object" and "raw" in schema["properties"]
        assert "$ref" not in json.dumps(schema)
    assert KeyFormat(KEYS.world("events")).schema_name == "carlaverse.WorldEvent"
    assert KeyFormat("carlaverse/enc/not/a/known/key").schema_name == "carlaverse.Raw"


def test_views_name_fields_and_expand_bulk_rows() -> None:
    pose = m.Pose(7, 1.5, 1.0, 2.0, yaw=0.25)
    assert to_view(pose)["yaw"] == 0.25 and to_view(pose)["seq"] == 7
    rows = np.zeros(2, dtype=m.NPC_DTYPE)
    rows["x"] = [1.0, 2.0]
    view = to_view(m.NpcBatch.pack(1, 0.5, ["n1", "n2"], rows))
    assert [r["x"] for r in view["rows"]] == [1.0, 2.0]
    assert to_view(m.Spawned(1, 2.0, "a", "car"))["type"] == "spawned"
    # a payload that is not a whole number of rows is shown as it is, not refused
    assert isinstance(to_view(m.NpcBatch(1, 0.5, ["n"], b"\x00" * 5))["rows"], bytes)


def test_a_pose_envelope_carries_session_time_and_seq() -> None:
    encoded = KeyFormat(KEYS.pose("a", "t0_0")).encode(m.POSE.encode(m.Pose(42, 12.25, 0.0, 0.0)))
    assert (encoded.t, encoded.seq, encoded.error) == (12.25, 42, "")
    bad = KeyFormat(KEYS.pose("a", "t0_0")).encode(b"short")
    assert bad.error and bad.t is None
    deleted = KeyFormat(KEYS.pose("a", "t0_0")).encode(b"", kind="delete")
    assert payload_of(deleted.data) == (b"", "delete")
