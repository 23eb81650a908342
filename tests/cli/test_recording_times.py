"""Times a person types: seconds from the recording's start, checked against its span by one
piece of code (`recording.timeline`) for every command that takes one."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.recording.reading import is_finished
from carlaverse.recording.sink import McapSink
from carlaverse.recording.timeline import OutOfRange, RecordingSpan, recording_span

T0_NS = 1_700_000_000 * 10**9  # [ns] the recorder's wall clock at session time 0
SESSION_T0_S = 500.0  # [s] the session clock when the recording starts (it joined late)
LATENCY_NS = 3_000_000  # [ns] every sample arrives 3 ms after its session time
SECONDS = 10.0  # [s] poses from session time 500 to 510


def write_recording(path: Path) -> None:
    """One ego driving east at 5 m/s for SECONDS at 50 Hz, from the recording's start."""
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    sink.write(keys.node("ego-0"), b"", T0_NS + LATENCY_NS)  # its liveliness, as recorded
    for k in range(int(SECONDS * 50) + 1):
        t = SESSION_T0_S + k / 50
        pose = m.Pose(k, t, 5.0 * k / 50, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0, 0.0)
        at = T0_NS + round(k / 50 * 1e9) + LATENCY_NS
        sink.write(keys.pose("ego-0", "t0_0"), m.POSE.encode(pose), at)
    sink.close()


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("times") / "ten.mcap"
    write_recording(path)
    return path


def test_the_span_is_on_the_session_clock(recording: Path) -> None:
    # The first pose says session time 500 and was received 3 ms later: the offset between
    # the clocks is 3 ms, and the first and last samples (poses) sit at 500 and 510 s.
    span = recording_span(recording)
    assert span.start == pytest.approx(SESSION_T0_S, abs=1e-9)
    assert span.end == pytest.approx(SESSION_T0_S + SECONDS, abs=1e-9)
    assert span.session_time(2.5, "--at") == pytest.approx(502.5, abs=1e-9)
    assert span.session_time(505.0, "--at-session", session=True) == 505.0
    assert span.from_start(507.25) == pytest.approx(7.25, abs=1e-9)


def test_a_killed_recorders_file_has_its_span_read_through(tmp_path: Path) -> None:
    # No summary (the recorder never closed it): the span comes from reading the samples,
    # the same 500 ... 502 s the poses written say.
    keys, path = Keys("rec"), tmp_path / "killed.mcap"
    sink = McapSink(path, monotonic=time.monotonic)
    for k in range(101):
        pose = m.Pose(k, SESSION_T0_S + k / 50, 0.0, 0.0)
        sink.write(keys.pose("ego-0", "t0_0"), m.POSE.encode(pose), T0_NS + k * 20_000_000)
    sink.flush()  # the chunk is on disk; no close, so no summary
    assert not is_finished(path)
    span = recording_span(path)
    assert span.start == pytest.approx(SESSION_T0_S, abs=1e-9)
    assert span.end == pytest.approx(SESSION_T0_S + 2.0, abs=1e-9)
    sink.close()


@pytest.mark.parametrize(
    ("value", "session", "says"),
    [
        (99.0, False, "--at 99 s is past the recording's end: valid 0.0–10.0 s from start"),
        (-1.0, False, "--at -1 s is before the recording's start: valid 0.0–10.0 s from start"),
        (20.0, True, "--at 20 s is before the recording's start: valid 500.000–510.000 s "
                     "session time (valid 0.0–10.0 s from start)"),
        (float("nan"), False, "--at nan: give seconds, valid 0.0–10.0 s from start"),
    ],
)  # fmt: skip
def test_a_time_outside_names_the_valid_range(value: float, session: bool, says: str) -> None:
    with pytest.raises(OutOfRange) as raised:
        RecordingSpan(500.0, 510.0).session_time(value, "--at", session=session)
    assert str(raised.value) == says


def test_the_printed_end_lies_inside_the_recording() -> None:
    # 41.36 s long: printed as 41.3 (rounded down), so typing back what was printed works
    span = RecordingSpan(0.0, 41.36)
    with pytest.raises(OutOfRange) as raised:
        span.session_time(41.4, "--at")
    assert str(raised.value).endswith("valid 0.0–41.3 s from start")
    assert span.session_time(41.3, "--at") == 41.3


def test_render_past_the_end_exits_2_naming_the_range(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.png"
    assert main(["render", str(recording), "--at", "99", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "--at 99 s is past the recording's end: valid 0.0–10.0 s from start" in err
    argv = ["render", str(recording), "--at-session", "99", "--out", str(out)]
    assert main(argv) == 2
    assert "valid 500.000–510.000 s session time" in capsys.readouterr().err
    assert not out.exists()


# ---------------------------------------------------------------- audio render


@pytest.fixture(scope="module")
def late_siren(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scenes at 20 Hz over 2 s; a siren 10 m east of the listener sounds from 1.0 s only."""
    from tests.audio.measure import scenes, write_recording

    siren = ("s", "siren", 100.0, 1.0, 0.0, (10.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    made = scenes([siren], 2.0)
    made = [s if s.t >= 1.0 else m.AudioScene(s.seq, s.t, s.listener, []) for s in made]
    return write_recording(tmp_path_factory.mktemp("audio") / "siren.mcap", made)


def _audio(recording: Path, out: Path, *extra: str) -> int:
    from tests.audio.measure import LISTENER

    return main(["audio", "render", str(recording), "--listener", LISTENER, "--out", str(out),
                 *extra])  # fmt: skip


def _rms(path: Path) -> float:
    from carlaverse.audio.wav import read_wav

    samples, _ = read_wav(path)
    return float(np.sqrt(np.mean(samples**2)))


def test_audio_at_seeks_and_says_where_it_is(
    late_siren: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The recording's first sample is the first scene, at session time 0: --at counts from it.
    # From 1.2 s the siren sounds; from 0.2 s for 0.3 s it has not started: silence.
    loud, quiet = tmp_path / "loud.wav", tmp_path / "quiet.wav"
    assert _audio(late_siren, loud, "--at", "1.2", "--duration", "0.3", "--json") == 0
    out, err = capsys.readouterr()
    summary = json.loads(out)
    assert summary["at"] == pytest.approx(1.2, abs=1e-6)
    block_s = 512 / 48_000  # the renderer writes whole blocks: at most one past the duration
    assert 0.3 <= summary["seconds"] < 0.3 + block_s + 1e-3
    assert "0.0% rendered (at 1.2 s from start)" in err
    assert "100.0% rendered (at 1.5 s from start)" in err
    assert _audio(late_siren, quiet, "--at", "0.2", "--duration", "0.3") == 0
    assert _rms(quiet) == 0.0 and _rms(loud) > 0.01


def test_audio_at_outside_the_recording_exits_2_naming_the_range(
    late_siren: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # scenes (and poses) from 0 to 1.95 s: the range printed rounds its end down to 1.9
    out = tmp_path / "x.wav"
    assert _audio(late_siren, out, "--at", "99") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "--at 99 s is past the recording's end: valid 0.0–1.9 s from start" in err
    assert _audio(late_siren, out, "--at", "1", "--duration", "0") == 2
    assert "--duration 0: give seconds > 0" in capsys.readouterr().err
    assert not out.exists()


# ---------------------------------------------------------------- view


def test_view_puts_every_row_on_a_from_start_timeline_too(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pyarrow as pa
    import rerun.chunk as rrc

    rrd = tmp_path / "ten.rrd"
    assert main(["view", str(recording), "--save", str(rrd)]) == 0
    assert "0.0–10.0 s from the recording's start" in capsys.readouterr().err
    boxes = 0
    for chunk in rrc.RrdReader(rrd).stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        session = np.array(batch.column("sim_time").cast(pa.int64()).to_pylist()) / 1e9
        start = np.array(batch.column("from_start").cast(pa.int64()).to_pylist()) / 1e9
        # the recording starts at session time 500: every row's two stamps are 500 s apart
        assert np.allclose(session - start, SESSION_T0_S, atol=1e-6), chunk.entity_path
        if chunk.entity_path == "/world/egos/ego-0" and "Boxes3D:centers" in batch.schema.names:
            # the ego drives east at 5 m/s from x = 0 at the start: x = 5 m/s x from_start
            x = [c[0][0] for c in batch.column("Boxes3D:centers").to_pylist()]
            assert np.allclose(x, 5.0 * start, atol=1e-3)
            boxes += len(x)
    assert boxes > 100  # the view drew the ego in most of its 200 frames
