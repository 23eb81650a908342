"""Where rendered blocks go: a PortAudio stream, or a simulated device that plays them at
real-time pace from a clock. Both pull from one `BlockQueue` and count underruns the same way.

    out = open_output(config, channels)      # OutputError (one line) when it cannot open
    out.queue.put(block, stamp, timeout_s)   # the renderer prefills the queue, then
    out.start()                              # the device plays; put waits while it is full
    out.close(); out.underruns, out.latencies_s

A block's `stamp` is when the newest emitter update it carries arrived (monotonic [s], or
None); the device notes, for each new stamp, how long after it the block began to play:
the latency from an emitter update to the ear.
"""

from __future__ import annotations

import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from carlaverse.audio.config import AudioConfig
from carlaverse.audio.wav import WavWriter

LATENCIES_KEPT = 72_000  # an hour of scenes at 20 Hz

Clock = Callable[[], float]


class OutputError(RuntimeError):
    """The audio output cannot be opened or died; the message says what is missing."""


class BlockQueue:
    """Blocks waiting to be played, at most `capacity`; `put` waits for room (that is what
    paces the renderer), `take` never waits (a device callback must not)."""

    def __init__(self, capacity: int) -> None:
        self._queue: queue.Queue[tuple[np.ndarray, float | None]] = queue.Queue(capacity)

    def put(self, block: np.ndarray, stamp: float | None, timeout_s: float) -> bool:
        try:
            self._queue.put((block, stamp), timeout=timeout_s)
        except queue.Full:
            return False
        return True

    def take(self) -> tuple[np.ndarray, float | None] | None:
        try:
            return self._queue.get_nowait()
        except queue.Empty:
            return None

    def full(self) -> bool:
        return self._queue.full()


class Output:
    """The part both devices share: the queue, the counters, what playing a block means."""

    def __init__(self, config: AudioConfig, channels: int, clock: Clock) -> None:
        self.block = config.block_size
        self.channels = channels
        self.rate = config.sample_rate_hz
        self.queue = BlockQueue(config.output.prefill_blocks)
        self.clock = clock
        self.played = 0
        self.underruns = 0  # blocks the device wanted and the renderer had not made
        # per scene played (~20 Hz), the newest LATENCIES_KEPT: bounded over a long session,
        # and appending never reallocates a growing list in the device's callback
        self.latencies_s: deque[float] = deque(maxlen=LATENCIES_KEPT)
        self.device = ""
        self.started_at: float | None = None  # clock time the device began to play
        self._last_stamp: float | None = None

    def playing_s(self) -> float:
        """[s] since the device began to play (0 before)."""
        return 0.0 if self.started_at is None else self.clock() - self.started_at

    def next_block(self) -> np.ndarray:
        """The block to play now (silence on an underrun, counted)."""
        item = self.queue.take()
        if item is None:
            self.underruns += 1
            return np.zeros((self.block, self.channels), dtype=np.float32)
        block, stamp = item
        if stamp is not None and stamp != self._last_stamp:
            self._last_stamp = stamp
            self.latencies_s.append(self.clock() - stamp)
        self.played += 1
        return block

    def close(self) -> None:
        raise NotImplementedError


class SimulatedOutput(Output):
    """Plays one block per block period by `clock`, in a thread of its own; never late by
    more than the OS makes it, never early, and it does not catch up in a burst after a stall
    (a real device would have played silence then: those are underruns)."""

    def __init__(self, config: AudioConfig, channels: int, clock: Clock = time.monotonic):
        super().__init__(config, channels, clock)
        self.device = "simulated"
        self._wav = WavWriter(config.output.wav, channels, self.rate) if config.output.wav else None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="audio-sim-out", daemon=True)

    def start(self) -> SimulatedOutput:
        self.started_at = self.clock()
        self._thread.start()
        return self

    def _run(self) -> None:
        period = self.block / self.rate
        deadline = self.clock()
        while not self._stop.is_set():
            block = self.next_block()
            if self._wav is not None:
                self._wav.write(block)
            deadline += period
            late = self.clock() - deadline
            if late > period:
                self.underruns += int(late // period)  # periods that passed without a block
                deadline += (late // period) * period
            self._stop.wait(max(0.0, deadline - self.clock()))

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        if self._wav is not None:
            self._wav.close()


class PortAudioOutput(Output):
    """A sounddevice output stream whose callback pulls blocks from the queue."""

    def __init__(self, config: AudioConfig, channels: int, clock: Clock = time.monotonic):
        super().__init__(config, channels, clock)
        self._stream = _open_stream(config, channels, self._callback)
        self.device = str(self._stream.device)

    def start(self) -> PortAudioOutput:
        self.started_at = self.clock()
        self._stream.start()
        return self

    def _callback(self, outdata: np.ndarray, frames: int, _time: object, status: object) -> None:
        if getattr(status, "output_underflow", False):
            self.underruns += 1
        outdata[:] = self.next_block()[:frames]

    def close(self) -> None:
        self._stream.stop()
        self._stream.close()


def _open_stream(config: AudioConfig, channels: int, callback: Callable) -> Any:
    try:
        import sounddevice as sd
    except (ImportError, OSError) as exc:
        hint = "install libportaudio2 and 'carlaverse[audio]', or use output.backend: sim"
        raise OutputError(f"audio output needs PortAudio: {exc} ({hint})") from exc
    try:
        return sd.OutputStream(
            samplerate=config.sample_rate_hz, blocksize=config.block_size, channels=channels,
            dtype="float32", callback=callback, device=config.output.device,
        )  # fmt: skip
    except Exception as exc:  # sounddevice raises PortAudioError and ValueError for devices
        raise OutputError(f"cannot open audio output {config.output.device or 'default'}: "
                          f"{exc} (or set output.backend: sim)") from exc  # fmt: skip


def open_output(config: AudioConfig, channels: int, clock: Clock = time.monotonic) -> Output:
    """The configured output, not yet started (start it once the renderer runs)."""
    if config.output.backend == "sim":
        return SimulatedOutput(config, channels, clock)
    return PortAudioOutput(config, channels, clock)
