"""16-bit PCM WAV output, written as it is rendered (a long recording never sits in memory)."""

from __future__ import annotations

import wave
from pathlib import Path
from types import TracebackType

import numpy as np

FULL_SCALE = 32767


class WavWriter:
    """Multi-channel 16-bit WAV; channel order as the layout's (WAV/SMPTE for 5.1)."""

    def __init__(self, path: str | Path, channels: int, sample_rate_hz: int) -> None:
        self.path = Path(path)
        try:
            self._wave = wave.open(str(self.path), "wb")  # noqa: SIM115 - closed by close()
        except OSError as exc:
            raise OSError(f"cannot write {self.path}: {exc.strerror}") from exc
        self._wave.setnchannels(channels)
        self._wave.setsampwidth(2)
        self._wave.setframerate(sample_rate_hz)
        self.frames = 0
        self.clipped = 0  # samples beyond full scale (the limiter should leave none)

    def write(self, block: np.ndarray) -> None:
        """(samples × channels) float within ±1."""
        scaled = np.rint(block * FULL_SCALE)
        self.clipped += int(np.count_nonzero(np.abs(scaled) > FULL_SCALE))
        pcm = np.clip(scaled, -FULL_SCALE, FULL_SCALE).astype("<i2")
        self._wave.writeframes(pcm.tobytes())
        self.frames += len(block)

    def close(self) -> None:
        self._wave.close()

    def __enter__(self) -> WavWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        self.close()


def read_wav(path: str | Path) -> tuple[np.ndarray, int]:
    """(samples × channels) float in ±1, and the sample rate: for tests and tools."""
    with wave.open(str(path), "rb") as w:
        data = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2")
        return data.reshape(-1, w.getnchannels()) / FULL_SCALE, w.getframerate()
