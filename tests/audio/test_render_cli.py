"""`carlaverse audio render`: a recording written by the project's own sink, rendered in
process through the CLI into 16-bit multi-channel WAVs; user errors in one line."""

from __future__ import annotations

import re
import wave
from pathlib import Path

import numpy as np
import pytest

from carlaverse.cli import main
from tests.audio.measure import LISTENER, RATE, scenes, write_recording

KINDS_DRIVES = {"engine": (2500.0, 0.8), "tyres": (25.0, 1.0), "siren": (1.0, 0.0),
                "construction": (1.0, 0.0), "leaves": (1.0, 0.0), "water": (1.0, 0.0),
                "rain": (1.0, 0.0), "wind": (1.0, 0.0)}  # fmt: skip


def crowd(n: int, seed: int = 7) -> list:
    """n loud emitters of every kind around the listener, moving in all directions."""
    rng = np.random.default_rng(seed)
    kinds = list(KINDS_DRIVES)
    motions = []
    for i in range(n):
        kind = kinds[i % len(kinds)]
        a, b = KINDS_DRIVES[kind]
        x, y = rng.uniform(-60.0, 60.0, 2)
        vx, vy = rng.uniform(-25.0, 25.0, 2)
        extent = 30.0 if kind in ("rain", "wind", "leaves", "water", "construction") else 0.0
        motions.append((f"e{i}", kind, 105.0, a, b, (x, y, 1.0), (vx, vy, 0.0), extent))
    return motions


@pytest.fixture(scope="module")
def crowd_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("audio") / "crowd.mcap"
    return write_recording(path, scenes(crowd(64), 2.0))


def _wav(path: Path) -> tuple[np.ndarray, wave.Wave_read]:
    with wave.open(str(path), "rb") as w:
        data = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2")
        return data.reshape(-1, w.getnchannels()), w


def test_64_emitters_render_without_nan_or_clipping(
    crowd_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "crowd.wav"
    code = main(["audio", "render", str(crowd_recording), "--listener", LISTENER,
                 "--out", str(out), "--json"])  # fmt: skip
    assert code == 0
    summary = capsys.readouterr().out
    assert '"emitters_max": 64' in summary and '"clipped_samples": 0' in summary
    assert '"dropped": {}' in summary
    pcm, w = _wav(out)
    assert w.getsampwidth() == 2 and w.getnchannels() == 2 and w.getframerate() == RATE
    assert pcm.shape[0] >= 2.0 * RATE
    peak = int(np.abs(pcm.astype(np.int32)).max())
    # Loud enough to need the limiter, which holds it under full scale; never clipped.
    assert 20000 < peak <= int(0.98 * 32767) + 1


@pytest.mark.parametrize(("layout", "channels"), [("5.1", 6), ("ring8", 8)])
def test_speaker_layouts_write_one_channel_per_speaker(tmp_path: Path, layout: str,
                                                        channels: int) -> None:  # fmt: skip
    recording = write_recording(tmp_path / "few.mcap", scenes(crowd(16, seed=3), 0.8))
    out = tmp_path / f"{layout}.wav"
    assert main(["audio", "render", str(recording), "--listener", LISTENER,
                 "--out", str(out), "--layout", layout]) == 0  # fmt: skip
    pcm, w = _wav(out)
    assert w.getnchannels() == channels and w.getsampwidth() == 2
    rms = np.sqrt(np.mean(pcm.astype(np.float64) ** 2, axis=0))
    # Every speaker carries sound, and so does 5.1's LFE (tests/audio/test_lfe.py: how).
    assert np.all(rms > 100.0), f"every channel carries sound: {rms}"


def test_a_wrong_listener_or_file_is_one_clear_line(
    crowd_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    out = str(tmp_path / "x.wav")
    assert main(["audio", "render", str(crowd_recording), "--listener", "nobody",
                 "--out", out]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no audio/nobody" in err and LISTENER in err
    assert main(["audio", "render", str(tmp_path / "missing.mcap"), "--listener", LISTENER,
                 "--out", out]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "missing.mcap: no such recording" in err
    assert main(["audio", "render", str(crowd_recording), "--listener", LISTENER,
                 "--out", out, "--layout", "ring2"]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "ring2" in err


def test_progress_runs_from_0_to_100_percent(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Progress is the fraction of the output rendered: nothing when the render starts, all of
    it when the WAV is complete, never going back (issue 43.8: it began at 58.2 % and never said
    100 %). A render shorter than the reporting period still shows both ends."""
    recording = write_recording(tmp_path / "tiny.mcap", scenes(crowd(2, seed=5), 0.3))
    assert main(["audio", "render", str(recording), "--listener", LISTENER,
                 "--out", str(tmp_path / "tiny.wav")]) == 0  # fmt: skip
    err = capsys.readouterr().err
    percents = [float(p) for p in re.findall(r"carlaverse audio: +([\d.]+)% rendered", err)]
    assert percents[0] == 0.0 and percents[-1] == 100.0, err
    assert percents == sorted(percents), err


@pytest.mark.parametrize("layout", ["7.1", "ring2", "ring65"])
def test_an_unknown_layout_is_one_line_naming_the_accepted_ones(
    crowd_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture, layout: str
) -> None:
    """The layouts the README and --help document: binaural, stereo, quad, 5.1 and a ring of
    3 to 64 speakers. A wrong one is a usage error (exit 2) said in words, not as the
    validator's regular expression (issue 43.8)."""
    assert main(["audio", "render", str(crowd_recording), "--listener", LISTENER,
                 "--out", str(tmp_path / "x.wav"), "--layout", layout]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--layout {layout!r}" in err, err
    for name in ("binaural", "stereo", "quad", "5.1", "ringN", "3 to 64"):
        assert name in err, err
    assert "regex" not in err and "(?" not in err and "$." not in err, err
