"""Record a live session into MCAP and read it back with the `mcap` library."""

from __future__ import annotations

import json
import time
from collections import Counter
from pathlib import Path

import zenoh
from mcap.reader import make_reader

from carlaverse import messages
from carlaverse.keys import Keys
from carlaverse.recording.archive import CONFIG_ATTACHMENT, SCENARIO_ATTACHMENT
from carlaverse.recording.reading import iter_samples, read_attachments, read_metadata
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.sink import McapSink
from tests.recording.conftest import GatedSink, World
from tests.support import wait_until

FUTURE_KEY = "carlaverse/rec/future/thing"  # a key this build has no type for


def _record(world: World, path: Path, publish_s: float = 1.5) -> Counter[str]:
    """Record while the world publishes; returns what the publishers report, per key."""
    session = world.connect()
    sink = McapSink(path, monotonic=time.monotonic)
    recorder = Recorder(session, Keys("rec"), sink)
    try:
        recorder.start()
        world.wait_matched()
        world.publish_for(publish_s)
        published = Counter(world.synthetic.published)
        bad_skeleton = Keys("rec").ego("ego-0", "skeleton")
        for key, payload in ((FUTURE_KEY, b"\x00\x01future"), (bad_skeleton, b"\xc1garbage")):
            world.session.put(key, payload)
            published[key] += 1
        total = sum(published.values())
        wait_until(lambda: recorder.stats().received >= total, 10, f"{total} samples received")
        wait_until(lambda: recorder.stats().attachments >= 3, 10, "configs archived")
        stats = recorder.stop()
    finally:
        session.close()
    assert stats.dropped == 0 and stats.failure == ""
    return published


def test_every_key_recorded_with_publisher_counts_and_configs(world: World, tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    published = _record(world, path)

    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None, "a stopped recorder leaves an indexed file"
        topics = {cid: ch.topic for cid, ch in summary.channels.items()}
        counts = {topics[cid]: n for cid, n in summary.statistics.channel_message_counts.items()}
        schemas = {summary.schemas[ch.schema_id].name for ch in summary.channels.values()}
        assert all(ch.message_encoding == "json" for ch in summary.channels.values())
        assert all(s.encoding == "jsonschema" for s in summary.schemas.values())
        assert summary.chunk_indexes, "chunked"
        assert {c.compression for c in summary.chunk_indexes} == {"zstd"}

    for key, n in published.items():
        assert counts.get(key) == n, f"{key}: published {n}, recorded {counts.get(key)}"
    # the authority's answers are kept as messages too, for view and replay
    for query in ("map", "scenario", "snapshot", "configs"):
        assert counts.get(Keys("rec").authority(query), 0) >= 1, query
    assert {"carlaverse.Pose", "carlaverse.NpcBatch", "carlaverse.WorldEvent"} <= schemas
    assert "carlaverse.Raw" in schemas  # the unknown key is still recorded

    attachments = read_attachments(path)
    for node_id, config_yaml in world.synthetic.configs.items():
        assert attachments[CONFIG_ATTACHMENT.format(node_id=node_id)] == config_yaml.encode()
    assert attachments[SCENARIO_ATTACHMENT] == world.synthetic.scenario_yaml.encode()

    meta = read_metadata(path)
    assert meta["carlaverse.session"]["session"] == "rec"
    assert int(meta["carlaverse.session"]["start_time_ns"]) > 0
    assert meta["carlaverse.session"]["zenoh_version"].startswith("1.")
    assert set(meta["carlaverse.roster"]) == set(world.synthetic.configs)
    assert json.loads(meta["carlaverse.roster"]["ego-0"])["kind"] == "scripted"
    assert meta["carlaverse.hostnames"]["recorder"]
    assert meta["carlaverse.summary"]["dropped"] == "0"


def test_payloads_are_kept_byte_for_byte_with_session_time(world: World, tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    _record(world, path, publish_s=0.5)
    truth: dict[str, list[bytes]] = {}
    for key, payload in world.synthetic.payloads or []:
        truth.setdefault(key, []).append(payload)
    got: dict[str, list[bytes]] = {}
    for sample in iter_samples(path):
        got.setdefault(sample.key, []).append(sample.payload)
        if "/pose/" in sample.key:  # ego/<id>/pose/<tile>
            pose = messages.POSE.decode(sample.payload)
            assert sample.publish_time_ns == round(pose.t * 1e9)  # publish time = session time
    for key, payloads in truth.items():
        assert got[key] == payloads, key
    assert got[FUTURE_KEY] == [b"\x00\x01future"]


def test_json_view_is_readable_and_names_fields(world: World, tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    _record(world, path, publish_s=0.3)
    with path.open("rb") as f:
        views = {}
        for schema, channel, message in make_reader(f).iter_messages():
            views.setdefault(channel.topic, (json.loads(schema.data), json.loads(message.data)))
    # The pose key ends in the tile the ego is in: take ego-0's first.
    schema, pose = next(v for k, v in views.items() if k.startswith("carlaverse/rec/ego/ego-0/"))
    assert set(schema["properties"]["msg"]["properties"]) >= {"x", "y", "yaw", "t"}
    assert "$ref" not in json.dumps(schema), "refs are inlined for simple JSON Schema readers"
    assert {"x", "y", "yaw", "raw"} <= set(pose["msg"]) | set(pose)
    _, npc = views["carlaverse/rec/world/npc"]
    assert len(npc["msg"]["rows"]) == 6 and "length" in npc["msg"]["rows"][0]
    _, skeleton = views["carlaverse/rec/ego/ego-0/skeleton"]
    assert "error" in skeleton and "msg" not in skeleton


def test_writer_loses_nothing_across_batches(world: World, tmp_path: Path) -> None:
    """A backlog longer than one writer batch (4096): every sample is written, in order."""
    path = tmp_path / "burst.mcap"
    session = world.connect()
    sink = GatedSink(path)
    recorder = Recorder(session, Keys("rec"), sink, archive=False)
    key = Keys("rec").pose("ego-0", "t0_0")
    payloads = [messages.POSE.encode(messages.Pose(i, i * 1e-3, 0.0, 0.0)) for i in range(10_000)]
    block = zenoh.CongestionControl.BLOCK
    publisher = world.session.declare_publisher(key, congestion_control=block)
    try:
        recorder.start()
        wait_until(lambda: publisher.matching_status.matching, 10, "the recorder listening")
        for payload in payloads:
            publisher.put(payload)
        wait_until(lambda: recorder.stats().received >= len(payloads), 20, "10 000 queued")
        sink.gate.set()
        stats = recorder.stop()
    finally:
        sink.gate.set()
        publisher.undeclare()
        session.close()
    assert stats.dropped == 0
    assert [s.payload for s in iter_samples(path) if s.key == key] == payloads
