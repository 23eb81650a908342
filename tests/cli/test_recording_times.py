"""Times a person types: seconds from the recording's start, checked against its span by one
piece of code (`recording.timeline`) for every command that takes one."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.timeline import OutOfRange, RecordingSpan, recording_span

T0_NS = 1_700_000_000 * 10**9  # [ns] the recorder's wall clock at session time 0
SESSION_T0_S = 500.0  # [s] the session clock when the recording starts (it joined late)
LATENCY_NS = 3_000_000  # [ns] every sample arrives 3 ms after its session time
SECONDS = 10.0  # [s] poses from session time 500 to 510


def write_recording(path: Path) -> None:
    """One ego driving east at 5 m/s for SECONDS at 50 Hz, its first pose the first sample."""
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
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


@pytest.mark.parametrize(
    ("value", "session", "says"),
    [
        (99.0, False, "--at 99 s is past the recording's end: valid 0.0–10.0 s from start"),
        (-1.0, False, "--at -1 s is before the recording's start: valid 0.0–10.0 s from start"),
        (20.0, True, "--at 20 s is before the recording's start: valid 500.000–510.000 s "
                     "session time (valid 0.0–10.0 s from start)"),
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
