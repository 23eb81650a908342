"""`backend: serial` — wheel speed from an ESP32 (or any microcontroller) on a serial port.

A trainer's own telemetry comes at ~1–4 Hz, too slow for the bike's physics; the paper's
rig measures the roller with a microcontroller instead. It sends one ASCII line per sample,
at 100–500 Hz, 115200 baud, 8N1:

    $WS,<seq>,<t_ms>,<revolutions>,<speed_mm_s>*<checksum>\\n

    seq          decimal uint32, +1 per line, wraps: a gap counts lost lines
    t_ms         decimal uint32, the microcontroller's millis() at the sample
    revolutions  decimal, wheel revolutions since it booted (e.g. 1234.125)
    speed_mm_s   decimal uint, wheel surface speed [mm/s]
    checksum     two hex digits: XOR of every byte between '$' and '*' (as in NMEA 0183)

Example: `$WS,17,5230,102.250,6944*1C` (the checksum depends on the exact text).
A line that breaks this is counted (`bad_lines`) and dropped. When the port vanishes (USB
unplugged) the reader closes it, reports speed 0 and tries to reopen it every `reopen_s`;
name the port by a stable path (`/dev/serial/by-id/...`) so a replug finds it again.
Revolutions keep counting across a replug (the microcontroller restarts at 0).

    speed_sensor:
      backend: serial
      options: {port: /dev/serial/by-id/usb-Espressif_ESP32-if00, baudrate: 115200}
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from typing import Annotated, NamedTuple

import msgspec
import serial

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.speed_sensor import SpeedSensor

log = logging.getLogger(__name__)
Positive = Annotated[float, msgspec.Meta(gt=0)]


class SerialSpeedOptions(StrictStruct):
    port: str
    baudrate: Annotated[int, msgspec.Meta(gt=0)] = 115200
    stale_s: Positive = 0.5  # [s] no line for this long: the wheel is reported still
    reopen_s: Positive = 0.2  # [s] between attempts to reopen a vanished port


class WheelLine(NamedTuple):
    seq: int
    t_ms: int
    revolutions: float
    speed_mps: float


class LineError(ValueError):
    """A line that is not a valid `$WS` sample."""


def checksum(body: str) -> int:
    value = 0
    for byte in body.encode("ascii"):
        value ^= byte
    return value


def format_line(seq: int, t_ms: int, revolutions: float, speed_mm_s: int) -> bytes:
    """The line the microcontroller sends (used by tests and a firmware's reference)."""
    body = f"WS,{seq},{t_ms},{revolutions:.3f},{speed_mm_s}"
    return f"${body}*{checksum(body):02X}\n".encode("ascii")


def parse_line(raw: bytes) -> WheelLine:
    try:
        text = raw.decode("ascii").strip()
    except UnicodeDecodeError as exc:
        raise LineError("not ASCII") from exc
    if not text.startswith("$") or "*" not in text:
        raise LineError(f"no $...* frame: {text[:40]!r}")
    body, _, check = text[1:].partition("*")
    if len(check) != 2 or check.upper() != f"{checksum(body):02X}":
        raise LineError(f"checksum {check!r} does not match {checksum(body):02X}")
    fields = body.split(",")
    if len(fields) != 5 or fields[0] != "WS":
        raise LineError(f"expected WS and 4 fields, got {body[:40]!r}")
    try:
        seq, t_ms, speed = int(fields[1]), int(fields[2]), int(fields[4])
        revolutions = float(fields[3])
    except ValueError as exc:
        raise LineError(f"a field is not a number: {body[:40]!r}") from exc
    if speed < 0 or revolutions < 0 or revolutions != revolutions:
        raise LineError(f"negative or NaN value: {body[:40]!r}")
    return WheelLine(seq, t_ms, revolutions, speed / 1000.0)


class SerialSpeedSensor(SpeedSensor):
    """Reads lines on a thread of its own; `read` returns the newest sample without waiting."""

    Options = SerialSpeedOptions

    def __init__(self, options: SerialSpeedOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.counters: Counter[str] = Counter()
        self._latest: tuple[float, WheelLine] | None = None  # (rx clock time, line)
        self._base_revs = 0.0  # revolutions counted before the last replug
        self._port: serial.Serial | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="esp32-speed", daemon=True)
        self._thread.start()

    def _read(self, now: float) -> tuple[float, float]:
        latest = self._latest
        if latest is None:
            return 0.0, self._base_revs
        rx_t, line = latest
        speed = line.speed_mps if now - rx_t <= self.options.stale_s else 0.0
        return speed, self._base_revs + line.revolutions

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self._port = serial.Serial(self.options.port, self.options.baudrate, timeout=0.1)
            except (serial.SerialException, OSError):
                self._stop.wait(self.options.reopen_s)
                continue
            self.counters["opens"] += 1
            lost: Exception | None = None
            try:
                self._read_lines(self._port)
            except (serial.SerialException, OSError) as exc:
                lost = exc
            self._port.close()
            self._replugged()  # before counting: whoever sees the count sees speed 0
            if lost is not None:
                self.counters["disconnects"] += 1
                log.warning("wheel-speed sensor on %s lost: %s", self.options.port, lost)

    def _read_lines(self, port: serial.Serial) -> None:
        while not self._stop.is_set():
            raw = port.readline()
            if not raw:
                continue  # timeout: nothing this 100 ms
            try:
                line = parse_line(raw)
            except LineError as exc:
                self.counters["bad_lines"] += 1
                log.debug("dropped a wheel-speed line: %s", exc)
                continue
            previous = self._latest
            if previous is not None and line.seq != (previous[1].seq + 1) % 2**32:
                self.counters["lost_lines"] += (line.seq - previous[1].seq - 1) % 2**32
            self._latest = (self.clock(), line)
            self.counters["lines"] += 1

    def _replugged(self) -> None:
        """The microcontroller restarts its count: keep what it had counted."""
        latest, self._latest = self._latest, None
        if latest is not None:
            self._base_revs += latest[1].revolutions

    def _close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
