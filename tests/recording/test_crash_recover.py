"""A SIGKILLed recorder leaves a file readable to its last chunk; --recover indexes it."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import pytest
import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from carlaverse import cli, messages
from carlaverse.keys import Keys
from carlaverse.recording.encoding import MESSAGE_ENCODING, SCHEMA_ENCODING, KeyFormat
from carlaverse.recording.reading import iter_samples, read_attachments, read_metadata
from tests.recording.conftest import World
from tests.support import Proc, wait_until


def _stream_messages(path: Path) -> int:
    """Messages the stream reader gets from an unfinished file (stops at the torn tail)."""
    count = 0
    with path.open("rb") as f:
        records = StreamReader(f, validate_crcs=True).records
        try:
            for record in records:
                count += isinstance(record, Message)
        except McapError:  # the incomplete last record
            pass
    return count


def test_sigkill_leaves_readable_chunks_and_recover_indexes_them(
    world: World, tmp_path: Path
) -> None:
    killed = tmp_path / "killed.mcap"
    recorder = Proc(["record", "--session", "rec", "--connect", world.endpoint, "-o", str(killed)])
    try:
        world.wait_matched(timeout=20)
        world.publish_for(2.5)  # > 2 chunk flush intervals
        wait_until(lambda: _stream_messages(killed) > 100, 10, "flushed chunks on disk")
    finally:
        recorder.stop(signal.SIGKILL)

    with killed.open("rb") as f, pytest.raises((McapError, ValueError, AssertionError)):
        summary = make_reader(f).get_summary()
        assert summary is not None  # the indexed reader has nothing to go on
    in_chunks = _stream_messages(killed)

    # every key's samples are a gap-free prefix of what was published
    samples = list(iter_samples(killed))
    assert len(samples) == in_chunks > 100
    truth: dict[str, list[bytes]] = {}
    for key, payload in world.synthetic.payloads or []:
        truth.setdefault(key, []).append(payload)
    got: dict[str, list[bytes]] = {}
    for s in samples:
        got.setdefault(s.key, []).append(s.payload)
    for key, payloads in got.items():
        if key in truth:
            assert payloads == truth[key][: len(payloads)], key
    # ego-0's poses, whichever tile's key each went on, in the order they were recorded
    poses = [s.payload for s in samples if s.key.startswith("carlaverse/rec/ego/ego-0/pose/")]
    assert [messages.POSE.decode(p).seq for p in poses] == list(range(1, len(poses) + 1))

    clean = tmp_path / "clean.mcap"
    assert cli.main(["record", "--recover", str(killed), "-o", str(clean)]) == 0
    with clean.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes
        assert summary.statistics.message_count == in_chunks
        assert sum(1 for _ in reader.iter_messages()) == in_chunks
        assert any(a.name.startswith("config/") for a in reader.iter_attachments())
        assert any(m.name == "carlaverse.session" for m in reader.iter_metadata())


def test_recover_of_a_finished_file_keeps_everything(world: World, tmp_path: Path) -> None:
    done = tmp_path / "done.mcap"
    argv = ["record", "--session", "rec", "--connect", world.endpoint, "-o", str(done)]
    argv += ["--duration", "2.5", "--progress-s", "0"]
    code: list[int] = []
    t = threading.Thread(target=lambda: code.append(cli.main(argv)))
    t.start()
    world.wait_matched(timeout=20)
    world.publish_for(0.5)
    t.join(timeout=20)
    assert code == [0]
    again = tmp_path / "again.mcap"
    assert cli.main(["record", "--recover", str(done), "-o", str(again)]) == 0
    original = [(s.key, s.payload) for s in iter_samples(done)]
    assert [(s.key, s.payload) for s in iter_samples(again)] == original
    assert cli.main(["record", "--recover", str(done), "-o", str(done)]) == 1  # never in place


def _older_recording_with_a_login(path: Path, secret: str) -> None:
    """What a recorder before redaction wrote: the login in configs, attachment, metadata."""
    config = yaml.safe_dump({"fabric": {"zenoh": {"transport/auth/usrpwd/password": secret}}})
    key = Keys("old").authority("configs")
    payload = messages.CONFIGS.encode(messages.ConfigsReply(messages.SCHEMA_VERSION, {"n": config}))
    fmt = KeyFormat(key)
    with path.open("wb") as f:
        writer = Writer(f, compression=CompressionType.NONE)
        writer.start(profile="carlaverse", library="an older carlaverse-recorder")
        schema = writer.register_schema(fmt.schema_name, SCHEMA_ENCODING, fmt.schema_bytes())
        channel = writer.register_channel(key, MESSAGE_ENCODING, schema)
        writer.add_message(channel, 1, fmt.encode(payload).data, 1, 0)
        writer.add_attachment(1, 1, "config/n.yaml", "application/yaml", config.encode())
        writer.add_metadata("carlaverse.extra", {"password": secret})
        writer.finish()


def test_recover_removes_a_login_an_older_recorder_kept(tmp_path: Path) -> None:
    secret = "pw-kept-by-an-older-recorder-7"
    old, clean = tmp_path / "old.mcap", tmp_path / "clean.mcap"
    _older_recording_with_a_login(old, secret)
    assert secret.encode() in old.read_bytes()
    assert (
        cli.main(["record", "--recover", str(old), "-o", str(clean), "--compression", "none"]) == 0
    )
    assert secret.encode() not in clean.read_bytes()
    [sample] = iter_samples(clean)
    assert "<redacted>" in messages.CONFIGS.decode(sample.payload).nodes["n"]
    assert secret.encode() not in read_attachments(clean)["config/n.yaml"]
    assert read_metadata(clean)["carlaverse.extra"] == {"password": "<redacted>"}
