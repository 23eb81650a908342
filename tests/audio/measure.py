"""Shared pieces of the audio tests: synthetic scenes, recordings of them, renders to WAV and
the measurements taken on the WAVs (levels, interaural differences, pitch)."""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from pathlib import Path

import msgspec
import numpy as np
from scipy.signal import butter, sosfiltfilt

from carlaverse import messages as m
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.hrtf import HrirSet, load_hrirs
from carlaverse.audio.listener import ego_listener
from carlaverse.audio.offline import play_scenes
from carlaverse.audio.renderer import build_renderer
from carlaverse.audio.wav import WavWriter, read_wav
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink

RATE = 48_000  # [Hz]
SCENE_HZ = 20.0  # like the authority's
LISTENER = "walker-1"
AT_ORIGIN = (0.0, 0.0, 0.0)  # head offset: the ears at the pose itself, facing east (+x)

# Emitters as functions of session time: (id, kind, level_db, drive_a, drive_b, position at 0,
# velocity[, extent_m]) — a straight-line motion is enough for every test.
Motion = tuple


def emitter(e: Motion, t: float) -> m.AudioEmitter:
    emitter_id, kind, level, a, b, p0, v, *extent = e
    x, y, z = (float(p0[i] + v[i] * t) for i in range(3))
    v = tuple(float(c) for c in v)
    return m.AudioEmitter(emitter_id, kind, x, y, z, *v, level_db=level,
                          extent_m=extent[0] if extent else 0.0, drive_a=a, drive_b=b)  # fmt: skip


def scenes(motions: Sequence[Motion], seconds: float) -> list[m.AudioScene]:
    """Scenes at SCENE_HZ from t = 0 to `seconds` (session time)."""
    times = np.arange(0.0, seconds, 1.0 / SCENE_HZ)
    return [m.AudioScene(i, float(t), LISTENER, [emitter(e, float(t)) for e in motions])
            for i, t in enumerate(times)]  # fmt: skip


def write_recording(path: Path, scene_list: Sequence[m.AudioScene], session: str = "lab") -> Path:
    """An MCAP as the recorder writes it: the listener's scenes and a standing pose."""
    keys = Keys(session)
    sink = McapSink(path, monotonic=time.monotonic)
    epoch_ns = time.time_ns()
    for s in scene_list:
        log_ns = epoch_ns + round(s.t * 1e9)
        pose = m.Pose(s.seq, s.t, 0.0, 0.0)
        sink.write(keys.ego(LISTENER, "pose"), m.encode_pose(pose), log_ns)
        sink.write(keys.audio(LISTENER), m.AUDIO_SCENE.encode(s), log_ns)
    sink.close()
    return path


def render_wav(path: Path, scene_list: Sequence[m.AudioScene], layout: str = "binaural",
               **config: object) -> tuple[np.ndarray, int]:  # fmt: skip
    """Render scenes for a listener standing at the origin facing east into a WAV at `path`
    and read it back: (samples × channels) in ±1."""
    cfg = msgspec.convert({"layout": layout, **config}, AudioConfig)
    renderer = build_renderer(cfg, kemar() if layout == "binaural" else None)
    listener = ego_listener(0.0, 0.0, 0.0, (0.0, 0.0), 0.0, AT_ORIGIN)
    renderer.place(listener)
    with WavWriter(path, renderer.channels, cfg.sample_rate_hz) as wav:
        play_scenes(renderer, scene_list, scene_list[-1].t + 1.0 / SCENE_HZ, wav.write)
    return read_wav(path)


@functools.cache
def kemar() -> HrirSet:
    return load_hrirs("kemar", RATE)


def level_db(x: np.ndarray) -> float:
    return float(10.0 * np.log10(np.mean(np.square(x)) + 1e-30))


def windows(x: np.ndarray, seconds: float) -> list[np.ndarray]:
    n = int(seconds * RATE)
    return [x[i : i + n] for i in range(0, len(x) - n + 1, n)]


def lowpass(x: np.ndarray, hz: float) -> np.ndarray:
    return sosfiltfilt(butter(4, hz, fs=RATE, output="sos"), x, axis=0)


def lag_s(left: np.ndarray, right: np.ndarray, max_lag_s: float = 1e-3) -> float:
    """Lag [s] of the right channel behind the left (> 0: the left hears it first), by
    cross-correlation within ±max_lag_s."""
    n = int(max_lag_s * RATE)
    lags = np.arange(-n, n + 1)
    core = slice(n, len(left) - n)
    corr = [np.dot(left[core], right[n + k : len(right) - n + k]) for k in lags]
    return float(lags[int(np.argmax(corr))] / RATE)


def peak_hz(x: np.ndarray) -> float:
    """Frequency [Hz] of the strongest spectral peak (Hann window, zero-padded FFT,
    parabolic interpolation on the log magnitude)."""
    n = 1 << 22
    spectrum = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    k = int(np.argmax(spectrum))
    a, b, c = np.log(spectrum[k - 1 : k + 2])
    return (k + 0.5 * (a - c) / (a - 2 * b + c)) * RATE / n


def band_level_db(x: np.ndarray, centre_hz: float) -> float:
    """Power [dB] in the third-octave band around `centre_hz`."""
    spectrum = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(len(x), 1.0 / RATE)
    band = (f >= centre_hz * 2 ** (-1 / 6)) & (f < centre_hz * 2 ** (1 / 6))
    return float(10.0 * np.log10(spectrum[band].sum()))
