"""A motion platform that writes one timestamped CSV row per frame, for offline analysis or
for feeding a rig's own playback tool."""

from __future__ import annotations

import csv
import time
from pathlib import Path

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.motion_packet import FIELDS, NEUTRAL_FRAME, MotionFrame
from carlaverse.hal.motion_server.platform import MotionPlatform

HEADER = ("t_s", "unix_time_s", "kind", *FIELDS)


class CsvPlatformOptions(StrictStruct):
    path: str  # file to write; an existing file is appended to
    flush_every: int = 1  # rows between flushes; 1 keeps the file complete after a crash


class CsvPlatform(MotionPlatform):
    """Rows: server clock [s], wall clock [s since 1970], 'frame'/'neutral', the five values."""

    Options = CsvPlatformOptions

    def __init__(self, options: CsvPlatformOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        path = Path(options.path).expanduser()
        try:
            fresh = not path.exists() or path.stat().st_size == 0
            self._file = path.open("a", newline="", encoding="utf-8")
        except OSError as exc:
            raise DeviceError(f"cannot open motion CSV {path}: {exc.strerror}") from exc
        self._writer = csv.writer(self._file)
        self._rows = 0
        if fresh:
            self._writer.writerow(HEADER)

    def _apply(self, frame: MotionFrame, now: float) -> None:
        self._row(now, "frame", frame)

    def _neutral(self, now: float) -> None:
        self._row(now, "neutral", NEUTRAL_FRAME)

    def _row(self, now: float, kind: str, frame: MotionFrame) -> None:
        values = (f"{v:.7g}" for v in msgspec.structs.astuple(frame))
        self._writer.writerow((f"{now:.6f}", f"{time.time():.6f}", kind, *values))
        self._rows += 1
        if self._rows % self.options.flush_every == 0:
            self._file.flush()

    def _close(self) -> None:
        self._file.close()
