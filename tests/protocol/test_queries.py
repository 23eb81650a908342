"""What docs/protocol.md says about queries, joins and events, checked on a live authority with
plain zenoh + msgpack, as a foreign client sees it."""

from __future__ import annotations

import re
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

PREFIX = "carlaverse/t"


class Foreign:
    """A bare Zenoh session speaking the documented protocol."""

    def __init__(self, endpoint: str) -> None:
        self.z = open_session(FabricSettings(mode="client", connect=[endpoint]))
        self.events: list[dict[str, Any]] = []
        self.stamps: list[str] = []  # the timestamp id of each world event
        self.present: set[str] = set()
        self._subs = [
            self.z.declare_subscriber(f"{PREFIX}/world/events", self._on_event),
            self.z.liveliness().declare_subscriber(
                f"{PREFIX}/node/*", self._on_presence, history=True
            ),
        ]

    def _on_event(self, sample: zenoh.Sample) -> None:
        self.stamps.append(str(sample.timestamp.get_id()) if sample.timestamp else "")
        self.events.append(msgpack.unpackb(sample.payload.to_bytes()))

    def _on_presence(self, sample: zenoh.Sample) -> None:
        node_id = str(sample.key_expr).rsplit("/", 1)[1]
        if sample.kind == zenoh.SampleKind.PUT:
            self.present.add(node_id)
        else:
            self.present.discard(node_id)

    def query(self, name: str, payload: bytes = b"") -> tuple[str, Any]:
        """('ok', decoded reply) or ('err', text) of the one reply the authority sends."""
        replies = list(self.z.get(f"{PREFIX}/authority/{name}", payload=payload, timeout=5.0))
        assert len(replies) == 1, f"authority/{name}: {len(replies)} replies"
        reply = replies[0]
        if reply.ok is not None:
            return "ok", msgpack.unpackb(reply.ok.payload.to_bytes())
        return "err", reply.err.payload.to_string()

    def join(self, **fields: Any) -> tuple[str, Any]:
        request = {"schema": m.SCHEMA_VERSION, "node_id": "lab-1",
                   "instance": uuid.uuid4().hex, "kind": "thirdparty", **fields}  # fmt: skip
        return self.query("join", msgpack.packb(request))

    def close(self) -> None:
        self.z.close()


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Foreign]:
    cluster = Cluster(Path(tmp_path_factory.mktemp("queries")))
    foreign = None
    try:  # everything started is stopped, even when a later step fails
        cluster.router()
        cluster.authority()
        foreign = Foreign(cluster.endpoint)
        # the readiness signal: the authority's token comes after its queryables
        wait_until(lambda: "authority" in foreign.present, 30, "the node/authority token")
        yield foreign
    finally:
        if foreign is not None:
            foreign.close()
        cluster.close()


def test_a_request_that_does_not_decode_gets_an_error_reply_in_plain_text(session) -> None:
    kind, text = session.query("join", msgpack.packb({"schema": m.SCHEMA_VERSION}))
    assert kind == "err" and "missing required field `node_id`" in text, text
    kind, text = session.join(instance=7)  # a str field given an int
    assert kind == "err" and "Expected `str`, got `int`" in text and "instance" in text, text
    kind, text = session.query("clock", b"\xc1")  # not MessagePack at all
    assert kind == "err" and text.startswith("bad clock request"), text


def test_a_join_that_decodes_but_is_unacceptable_is_a_refused_join_reply(session) -> None:
    kind, reply = session.join(schema=m.SCHEMA_VERSION + 1, node_id="lab-x")
    assert kind == "ok" and reply["accepted"] is False
    assert f"schema version {m.SCHEMA_VERSION + 1}" in reply["reason"]
    kind, reply = session.join(node_id="authority")
    assert kind == "ok" and not reply["accepted"] and "reserved" in reply["reason"]


def test_defaults_fill_omitted_fields_and_unknown_keys_are_ignored(session) -> None:
    kind, reply = session.join(node_id="lab-min", future_field=[1, 2])
    assert kind == "ok" and reply["accepted"], reply
    # a Zenoh id in hex: up to 32 digits (its text drops leading zeros)
    assert reply["schema"] == m.SCHEMA_VERSION
    assert re.fullmatch(r"[0-9a-f]{1,32}", reply["authority_instance"])
    # No scenario: each embodied node a row of its own (docs/protocol.md, Joining); the first
    # to ask starts at the origin heading east, a SpawnPoint array [x, y, z, yaw].
    assert reply["spawn"] == [0.0, 0.0, 0.0, 0.0]


def test_arrays_may_stop_before_defaulted_fields_and_carry_extra_ones() -> None:
    assert m.CLOCK_REPLY.decode(msgpack.packb([1.5])).known is False
    assert m.CLOCK_REPLY.decode(msgpack.packb([1.5, True, "a later field"])).known is True
    with pytest.raises(m.MessageError, match="at least length 1"):
        m.CLOCK_REPLY.decode(msgpack.packb([]))


def test_clock_replies_are_arrays_and_say_whether_the_asker_is_joined(session) -> None:
    kind, (t, known) = session.query("clock", msgpack.packb({"node_id": "nobody"}))
    assert kind == "ok" and isinstance(t, float) and known is False
    session.join(node_id="lab-clock", kind="observer", actor_kind="")
    _, (t2, known) = session.query("clock", msgpack.packb({"node_id": "lab-clock"}))
    assert known is True and t2 >= t


def test_spawned_names_the_node_kind_and_the_snapshot_lists_observers(session) -> None:
    assert session.join(node_id="lab-bike", kind="thirdparty", actor_kind="bicycle")[1]["accepted"]
    assert session.join(node_id="lab-obs", kind="observer", actor_kind="")[1]["accepted"]
    spawned = wait_until(
        lambda: [e for e in session.events if e.get("node_id") == "lab-bike"], 5, "spawned event"
    )
    assert spawned[0]["type"] == "spawned" and spawned[0]["kind"] == "thirdparty"
    assert spawned[0]["actor_kind"] == "bicycle"
    _, snapshot = session.query("snapshot")
    egos = {e["node_id"]: e for e in snapshot["egos"]}
    assert egos["lab-obs"]["actor_kind"] == "" and egos["lab-obs"]["pose"] is None
    assert egos["lab-bike"]["actor_kind"] == "bicycle" and egos["lab-bike"]["pose"] is None


def test_joins_are_validated_with_a_reason(session) -> None:
    refusals = {
        "actor_kind": ({"actor_kind": "spaceship"}, "unknown actor_kind 'spaceship'"),
        "no actor": ({"actor_kind": ""}, "only observers have no actor"),
        "rate": ({"pose_rate_hz": 0.0}, "pose_rate_hz = 0.0: must be in (0, 1000]"),
        "extent": ({"extent": [4.5, 1.8, 60.0]}, "extent.height = 60.0: must be in (0, 50]"),
        "mass": ({"mass_kg": -1.0}, "mass_kg = -1.0"),
        "config": ({"config_yaml": "a: [1"}, "config_yaml does not parse as YAML"),
        "instance": ({"instance": ""}, "instance is empty"),
    }
    for what, (fields, reason) in refusals.items():
        kind, reply = session.join(node_id="lab-bad", **fields)
        assert kind == "ok" and not reply["accepted"], what
        assert reason in reply["reason"], (what, reply["reason"])
    kind, text = session.join(node_id="lab-bad", mass_kg=float("nan"))  # not even decodable
    assert kind == "err" and "mass_kg" in text, text


def test_leave_takes_the_joined_instance_and_is_announced_as_left(session) -> None:
    instance = uuid.uuid4().hex
    assert session.join(node_id="lab-leave", instance=instance)[1]["accepted"]
    leave = {"node_id": "lab-leave", "instance": "not-the-joined-one"}
    assert session.query("leave", msgpack.packb(leave)) == ("ok", {"left": False})
    leave["instance"] = instance
    assert session.query("leave", msgpack.packb(leave)) == ("ok", {"left": True})
    despawned = wait_until(lambda: [e for e in session.events if e.get("node_id") == "lab-leave"
                                    and e["type"] == "despawned"], 5, "the leave")  # fmt: skip
    assert despawned[0]["reason"] == "left"


def test_world_messages_carry_the_authority_sessions_timestamp(session) -> None:
    _, reply = session.join(node_id="lab-stamp")
    wait_until(lambda: any(e.get("node_id") == "lab-stamp" for e in session.events), 5, "event")
    assert set(session.stamps) == {reply["authority_instance"]}


def test_a_second_instance_of_a_live_id_is_refused_with_a_reason(session) -> None:
    token = session.z.liveliness().declare_token(f"{PREFIX}/node/lab-dup")
    try:
        assert session.join(node_id="lab-dup")[1]["accepted"]
        wait_until(lambda: "lab-dup" in session.present, 5, "lab-dup's token")
        _, reply = session.join(node_id="lab-dup")  # another instance, same id
        assert not reply["accepted"] and "already in use" in reply["reason"], reply
    finally:
        token.undeclare()


def test_map_and_scenario_are_error_replies_without_a_scenario(session) -> None:
    assert session.query("map") == (
        "err", "this session has no map (the authority runs no scenario)"
    )  # fmt: skip
    assert session.query("scenario")[0] == "err"
    session.join(node_id="lab-cfg", config_yaml="node: {site: partner-lab}\n")
    kind, configs = session.query("configs")
    assert kind == "ok" and configs["nodes"]["lab-cfg"] == "node: {site: partner-lab}\n"
