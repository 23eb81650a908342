"""The file side of the recorder under hostile input: every value written raw or rejected."""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any

import msgspec
import yaml
import zenoh
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.admission import Budget, KeyAdmission
from carlaverse.recording.reading import iter_samples, read_attachments, read_metadata
from carlaverse.recording.recorder import Recorder
from carlaverse.recording.sink import McapSink
from carlaverse.redact import REDACTED
from carlaverse.transport.session import FabricSettings, open_session
from tests.recording.conftest import GatedSink
from tests.recording.hostile import hostile_payloads
from tests.support import wait_until

K = Keys("hostile")
T0_NS = 1_700_000_000_000_000_000  # [ns] a plausible receive time


def _sink(path: Path, **kwargs: Any) -> McapSink:
    return McapSink(path, monotonic=time.monotonic, **kwargs)


def _good(i: int) -> bytes:
    return m.encode_pose(m.Pose(i, 10.0 + i, 1.0, 2.0))


def test_every_hostile_value_is_kept_raw_between_good_ones(tmp_path: Path) -> None:
    path = tmp_path / "hostile.mcap"
    sink = _sink(path)
    expected = []
    for i, (key, payload, what) in enumerate(hostile_payloads(K)):
        for entry in ((K.pose("good", "t0_0"), _good(i)), (key, payload)):
            assert sink.write(*entry, T0_NS + len(expected)), what
            expected.append(entry)
    assert sink.write(K.pose("good", "t0_0"), _good(99), T0_NS + len(expected))
    expected.append((K.pose("good", "t0_0"), _good(99)))
    sink.close()

    samples = list(iter_samples(path))
    assert [(s.key, s.payload) for s in samples] == expected  # continuous, byte for byte
    hostile = [s for s in samples if "good" not in s.key]
    assert all(s.publish_time_ns == s.log_time_ns for s in hostile[:4]), "non-finite t"
    assert sink.stats.rejected == 0
    assert sink.stats.decode_errors >= 9  # all but the finite-but-absurd times


def test_receive_times_outside_mcap_and_keys_past_the_bound_are_rejected(tmp_path: Path) -> None:
    path = tmp_path / "bounds.mcap"
    # no token is known to this sink, so every key is a stranger's: two of them fit
    sink = _sink(path, admission=KeyAdmission(Budget(stranger_channels=2)))
    assert not sink.write(K.pose("a", "t0_0"), _good(1), -1)
    assert not sink.write(K.pose("a", "t0_0"), _good(2), 2**64)
    assert sink.write(K.pose("a", "t0_0"), _good(3), T0_NS)
    assert sink.write(K.pose("b", "t0_0"), _good(4), T0_NS + 1)
    assert not sink.write(K.pose("c", "t0_0"), _good(5), T0_NS + 2)  # a third key: over the bound
    assert sink.write(K.pose("a", "t0_0"), _good(6), T0_NS + 3)  # known keys still go in
    sink.close()
    assert sink.stats.rejected == 3
    assert [s.payload for s in iter_samples(path)] == [_good(3), _good(4), _good(6)]


numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**63), max_value=2**64 - 1),
)


@settings(max_examples=300, deadline=None)
@given(seq=st.integers(min_value=-(2**63), max_value=2**64 - 1), t=numbers)
def test_any_seq_and_time_a_message_can_carry_is_written(seq: int, t: float | int) -> None:
    payload = msgspec.msgpack.encode({"seq": seq, "t": t, "lights": []})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "t.mcap"
        sink = _sink(path)
        assert sink.write(K.world("lights"), payload, T0_NS)
        sink.close()
        [sample] = iter_samples(path)
    assert sample.payload == payload
    if isinstance(t, float) and not math.isfinite(t):
        assert sample.publish_time_ns == T0_NS


def test_configs_attachments_and_metadata_are_redacted_at_the_file(tmp_path: Path) -> None:
    """The writer's own gate: a recording keeps no login even if a node sent one."""
    secret = "pw-sekrit-0123456789"
    config = yaml.safe_dump({"fabric": {"zenoh": {"transport/auth/usrpwd/password": secret}}})
    reply = m.ConfigsReply(m.SCHEMA_VERSION, {"n1": config})
    path = tmp_path / "configs.mcap"
    sink = _sink(path, compression="none")
    sink.write(K.authority("configs"), m.CONFIGS.encode(reply), T0_NS)
    sink.write(K.authority("configs"), b"\x91" * 1000, T0_NS + 1)  # cannot be checked: withheld
    sink.attach("config/n1.yaml", "application/yaml", config.encode(), T0_NS)
    sink.metadata("carlaverse.extra", {"password": secret, "site": "tum"})
    sink.close()
    assert secret.encode() not in path.read_bytes()
    first, second = iter_samples(path)
    stored = yaml.safe_load(m.CONFIGS.decode(first.payload).nodes["n1"])
    assert stored["fabric"]["zenoh"]["transport/auth/usrpwd/password"] == REDACTED
    assert second.payload == b""
    assert secret.encode() not in read_attachments(path)["config/n1.yaml"]
    assert read_metadata(path)["carlaverse.extra"] == {"password": REDACTED, "site": "tum"}


class _FailingSink(McapSink):
    """A real sink that fails like a broken disk after `good` writes."""

    def __init__(self, path: Path, error: Exception, good: int = 1) -> None:
        super().__init__(path, monotonic=time.monotonic)
        self.error, self.good = error, good

    def write(self, *args: Any, **kwargs: Any) -> bool:
        if self.stats.messages >= self.good:
            raise self.error
        return super().write(*args, **kwargs)


def _put_poses(session: zenoh.Session, count: int, size: int = 0) -> None:
    for i in range(count):
        session.put(K.pose("a", "t0_0"), _good(i) + b"\x00" * size)


def test_a_writer_that_stops_is_reported_not_hidden(tmp_path: Path) -> None:
    for error in (OSError(28, "No space left on device"), RuntimeError("a bug")):
        session = open_session(FabricSettings())
        recorder = Recorder(session, K, _FailingSink(tmp_path / "f.mcap", error), archive=False)
        try:
            recorder.start()
            _put_poses(session, 5)
            failure = wait_until(lambda r=recorder: r.stats().failure, 10, "the failure reported")
            assert str(error) in failure
            assert str(error) in recorder.stop().failure
        finally:
            session.close()


def test_queued_payload_bytes_are_bounded_and_drops_counted(tmp_path: Path) -> None:
    session = open_session(FabricSettings())
    sink = GatedSink(tmp_path / "q.mcap")
    recorder = Recorder(session, K, sink, archive=False, queue_bytes=10_000)
    try:
        recorder.start()
        _put_poses(session, 50, size=1_000)  # ~1 kB each: 10 fit while the writer is held
        wait_until(lambda: recorder.stats().received + recorder.stats().dropped >= 50, 10, "50")
        held = recorder.stats()
        sink.gate.set()
        stats = recorder.stop()
    finally:
        sink.gate.set()
        session.close()
    assert 1 <= held.received <= 10 and held.dropped == 50 - held.received
    assert stats.written == held.received and stats.dropped == held.dropped
