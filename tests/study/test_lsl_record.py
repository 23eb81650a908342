"""Recording LSL streams into a session's MCAP: real outlets and inlets on loopback, a real
Zenoh session for the session clock, the real recorder writing the same file."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given
from hypothesis import strategies as st
from mcap.reader import make_reader

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.reading import iter_samples, read_channels, read_metadata
from carlaverse.recording.recorder import Recorder
from carlaverse.study.lsl_record import (
    LslRecording,
    SampleMapper,
    StreamMissing,
    StreamStats,
    record_lsl,
    resolve,
)
from carlaverse.study.lsl_sink import SharedSink, decode_sample, lsl_summaries, read_lsl
from tests.study.lsl_support import (
    ECG_RATE_HZ,
    HEART_RATE_BPM,
    SESSION_OFFSET_S,
    EcgOutlet,
    Fabric,
    lsl,
    open_fabric,
)
from tests.support import wait_until

# [s] the stated accuracy of LSL → session time on one host (docs/benchmarks.md, "LSL to
# session time"): the session clock's offset is bounded by half a clock query's round trip
# over Zenoh on loopback (~0.1-1 ms on a loaded 2-core machine), liblsl's time correction
# between two inlets of one host is ~µs. 5 ms leaves room for a stalled query on CI.
ACCURACY_S = 0.005


@pytest.fixture
def fabric() -> Iterator[Fabric]:
    with open_fabric() as fab:
        yield fab


def test_synthetic_ecg_lands_in_the_trial_mcap_on_session_time(
    fabric: Fabric, tmp_path: Path
) -> None:
    pylsl = lsl()
    ecg = EcgOutlet("ECG-rec")
    path = tmp_path / "trial.mcap"
    sink = SharedSink(path, monotonic=time.monotonic)
    recorder = Recorder(fabric.client, fabric.keys, sink, archive=False)
    recorder.start()
    recording = record_lsl(fabric.client, fabric.keys, sink, pylsl, ["ECG-rec"], timeout_s=5)
    ecg.wait_consumer()
    assert recording.follower.wait_synced(5), "no clock reply from the stand-in authority"
    sender = ecg.send_in_thread(3.0)
    fabric.publish_event(m.Notice(1, fabric.session_now(), "brake now"))  # the fabric's key
    sender.join(timeout=15)
    wait_until(lambda: recording.stats()[0].samples >= len(ecg.truth), 10, "every sample")
    (stats,) = recording.stop()
    recorder.stop()

    # Right count: every one of the 3 s × 250 Hz samples pushed, none twice.
    assert len(ecg.truth) == 3 * ECG_RATE_HZ
    assert (stats.samples, stats.bad_shape, stats.bad_time) == (750, 0, 0)
    recorded = [s for s in iter_samples(path) if s.key == "lsl/ECG-rec"]
    samples = [decode_sample(s.payload) for s in recorded]
    assert [s.seq for s in samples] == list(range(750))
    assert read_lsl(path) == {"lsl/ECG-rec": samples}

    # Session time: each sample's truth is the session time its outlet stamped it for.
    errors = [abs(s.t - truth) for s, truth in zip(samples, ecg.truth, strict=True)]
    assert max(errors) < ACCURACY_S, f"max error {max(errors) * 1e3:.3f} ms"
    # lsl_t is the producer's own stamp: truth − the offset the stand-in authority keeps.
    assert samples[0].lsl_t == pytest.approx(ecg.truth[0] - SESSION_OFFSET_S, abs=1e-6)
    assert abs(samples[0].correction_s) < 0.001  # one host: one clock
    assert recorded[0].publish_time_ns == round(samples[0].t * 1e9)

    # The R-peaks (the samples above half the R wave's 1.2 mV) sit on the beat's session
    # times t0 + k · 60/72 s, within the stated accuracy plus half a sample (2 ms).
    t0, period = ecg.truth[0], 60.0 / HEART_RATE_BPM
    peaks = [s.t for s in samples if s.values[0] is not None and s.values[0] > 1.0]
    assert len(peaks) >= 3
    for t in peaks:
        beat = round((t - t0) / period)
        assert abs(t - (t0 + beat * period)) < ACCURACY_S + 0.5 / ECG_RATE_HZ

    # The same file holds the fabric's keys, and the stream's info and stats.
    assert any(s.key.endswith("/world/events") for s in iter_samples(path))
    channel = read_channels(path)["lsl/ECG-rec"]
    assert (channel["lsl.type"], channel["lsl.channel_count"]) == ("ECG", "1")
    assert channel["lsl.nominal_srate"] == "250.0"
    assert "<unit>mV</unit>" in channel["lsl.info_xml"]
    meta = lsl_summaries(path)["lsl/ECG-rec"]
    assert meta["samples"] == "750"
    # 750 samples between first and last at 250 Hz: coverage (750 / (2.996 · 250 + 1)) = 1
    assert float(meta["coverage"]) == pytest.approx(1.0, abs=0.01)


def test_the_plain_mcap_reader_reads_the_channel_against_its_schema(
    fabric: Fabric, tmp_path: Path
) -> None:
    pylsl = lsl()
    ecg = EcgOutlet("ECG-plain")
    path = tmp_path / "plain.mcap"
    sink = SharedSink(path, monotonic=time.monotonic)
    recording = record_lsl(fabric.client, fabric.keys, sink, pylsl, ["ECG-plain"], timeout_s=5)
    ecg.wait_consumer()
    assert recording.follower.wait_synced(5)
    ecg.send(0.2)
    wait_until(lambda: recording.stats()[0].samples >= 50, 10, "50 samples")
    recording.stop()
    sink.close()

    with path.open("rb") as f:
        messages = list(make_reader(f).iter_messages(topics=["lsl/ECG-plain"]))
    assert len(messages) == 50
    for schema, channel, message in messages:
        assert (schema.name, schema.encoding, channel.message_encoding) == (
            "carlaverse.LslSample",
            "jsonschema",
            "json",
        )
        body = json.loads(message.data)
        jsonschema.validate(body, json.loads(schema.data))
        assert body["msg"]["t"] == pytest.approx(message.publish_time / 1e9, abs=1e-6)


def test_a_named_stream_that_is_absent_is_named_with_the_deadline() -> None:
    pylsl = lsl()
    present = EcgOutlet("EEG-present")
    assert present.outlet.have_consumers() is False
    started = time.monotonic()
    with pytest.raises(StreamMissing, match=r"NoSuchEEG not found within 0\.3 s") as caught:
        resolve(pylsl, ["EEG-present", "NoSuchEEG"], timeout_s=0.3)
    assert time.monotonic() - started < 3.0  # the deadline (a loaded machine may add to it)
    assert "streams seen: EEG-present@" in str(caught.value)  # what was there instead


def test_samples_of_the_wrong_width_or_time_are_counted_and_dropped() -> None:
    stats = StreamStats("EEG", "lsl/EEG")
    mapper = SampleMapper(channel_count=2, stats=stats)
    rows = [[1.0, 2.0], [1.0], [3.0, math.nan], [4.0, 5.0], [6.0, 7.0]]
    stamps = [10.0, 10.1, 10.2, math.nan, math.inf]
    out = mapper.map(rows, stamps, correction_s=0.5, to_session=lambda local: local + 100.0)
    assert (stats.bad_shape, stats.bad_time) == (1, 2)
    # pylsl: time_correction() is "the number that needs to be added to a time stamp that was
    # remotely generated via local_clock() to map it into the local clock domain"; so the
    # sample stamped 10.0 is at local 10.5, and at session 10.5 + 100.
    assert [(s.seq, s.t, s.lsl_t, s.values) for s in out] == [
        (0, 110.5, 10.0, [1.0, 2.0]),
        (1, 110.7, 10.2, [3.0, None]),  # NaN: a missing value, kept as null
    ]


def test_a_nan_timestamp_from_a_real_outlet_is_dropped(fabric: Fabric, tmp_path: Path) -> None:
    pylsl = lsl()
    info = pylsl.StreamInfo("EDA-nan", "EDA", 1, 0.0, "float32", "test-eda-nan")
    outlet = pylsl.StreamOutlet(info)
    sink = SharedSink(tmp_path / "nan.mcap", monotonic=time.monotonic)
    recording = record_lsl(fabric.client, fabric.keys, sink, pylsl, ["EDA-nan"], timeout_s=5)
    assert outlet.wait_for_consumers(5)
    now = pylsl.local_clock()
    for value, stamp in ((1.0, now), (2.0, math.nan), (3.0, now + 0.01)):
        outlet.push_sample([value], stamp)
    wait_until(lambda: sum(vars_of(recording.stats()[0])) >= 3, 10, "three samples pulled")
    (stats,) = recording.stop()
    sink.close()
    assert (stats.samples, stats.bad_time) == (2, 1)


def vars_of(stats: StreamStats) -> tuple[int, int, int]:
    return stats.samples, stats.bad_shape, stats.bad_time


def test_a_stream_gone_between_finding_and_opening_is_named(fabric: Fabric, tmp_path: Path) -> None:
    pylsl = lsl()
    gone = EcgOutlet("ECG-gone")
    (info,) = resolve(pylsl, ["ECG-gone"], timeout_s=5)
    del gone  # liblsl closes the outlet when its Python object goes
    sink = SharedSink(tmp_path / "gone.mcap", monotonic=time.monotonic)
    with pytest.raises(StreamMissing, match=r"ECG-gone@\S+ was found but did not open"):
        LslRecording(fabric.client, fabric.keys, sink, pylsl, [info])
    sink.close()


def test_without_an_authority_the_stream_says_it_has_no_session_time(
    fabric: Fabric, tmp_path: Path
) -> None:
    pylsl = lsl()
    ecg = EcgOutlet("ECG-noauth")
    sink = SharedSink(tmp_path / "noauth.mcap", monotonic=time.monotonic)
    # A session nobody serves the clock of: every clock query goes unanswered.
    recording = record_lsl(fabric.client, Keys("noauth"), sink, pylsl, ["ECG-noauth"], 5)
    ecg.wait_consumer()
    ecg.send(0.1)
    wait_until(lambda: recording.follower.unanswered > 0, 10, "an unanswered clock query")
    (stats,) = recording.stop()
    sink.close()
    assert stats.samples == 0
    assert stats.error == "no authority answered a clock query: no session time"
    assert read_metadata(tmp_path / "noauth.mcap")["lsl/ECG-noauth"]["error"] == stats.error


@given(
    st.lists(
        st.tuples(
            st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=4),
            st.floats(allow_nan=True, allow_infinity=True),
        ),
        max_size=40,
    ),
    st.floats(-10.0, 10.0),
)
def test_every_chunk_splits_into_written_and_counted_samples(
    chunk: list[tuple[list[float], float]], correction: float
) -> None:
    stats = StreamStats("X", "lsl/X")
    mapper = SampleMapper(channel_count=3, stats=stats)
    rows, stamps = [r for r, _ in chunk], [s for _, s in chunk]
    out = mapper.map(rows, stamps, correction, to_session=lambda local: local + 7.0)
    good = [(r, s) for r, s in chunk if len(r) == 3 and math.isfinite(s)]
    assert len(out) + stats.bad_shape + stats.bad_time == len(chunk)
    assert [s.seq for s in out] == list(range(len(good)))
    for sample, (row, stamp) in zip(out, good, strict=True):
        assert sample.t == stamp + correction + 7.0 and sample.lsl_t == stamp
        assert sample.values == [v if math.isfinite(v) else None for v in row]


def test_a_string_stream_is_recorded_as_text(fabric: Fabric, tmp_path: Path) -> None:
    pylsl = lsl()
    info = pylsl.StreamInfo("Gaze-events", "Markers", 1, 0.0, "string", "test-gaze-events")
    outlet = pylsl.StreamOutlet(info)
    path = tmp_path / "text.mcap"
    sink = SharedSink(path, monotonic=time.monotonic)
    recording = record_lsl(fabric.client, fabric.keys, sink, pylsl, ["Gaze-events"], 5)
    assert outlet.wait_for_consumers(5) and recording.follower.wait_synced(5)
    for text in ("fixation_start", "blink", "fixation_end"):
        outlet.push_sample([text])
    wait_until(lambda: recording.stats()[0].samples == 3, 10, "three text samples")
    recording.stop()
    sink.close()
    samples = read_lsl(path)["lsl/Gaze-events"]
    assert [s.values for s in samples] == [["fixation_start"], ["blink"], ["fixation_end"]]
