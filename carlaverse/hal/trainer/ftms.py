"""The FTMS trainer client, independent of how the bytes travel.

`FtmsTrainer` speaks the Fitness Machine Service through an `FtmsLink`: Bluetooth through bleak
(`ftms_ble`) or a simulated trainer in-process (`ftms_sim`). Both carry the same bytes
(`ftms_codec`), so everything above the link — taking control, commanding resistance,
reading Indoor Bike Data, taking control again after a reconnect — is tested without a radio.

The control loop never waits on the link: a command is written and its response arrives
later through a callback; a malformed notification or response is counted and dropped.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from typing import Protocol

from carlaverse.hal.device import Clock
from carlaverse.hal.trainer import TrainerDevice
from carlaverse.hal.trainer import ftms_codec as codec

log = logging.getLogger(__name__)

KMH = 1 / 3.6  # [m/s per km/h]
RESEND_S = 1.0  # [s] re-send an unchanged resistance this often (a trainer may drop one)
RESISTANCE_STEP = 0.5  # [%] a smaller change is not worth a BLE write


class LinkHandler(Protocol):
    def on_bike_data(self, data: bytes) -> None: ...
    def on_response(self, data: bytes) -> None: ...
    def on_connected(self, connected: bool) -> None: ...


class FtmsLink(Protocol):
    """How the bytes travel: writes never block; notifications come through the handler."""

    def start(self, handler: LinkHandler) -> None: ...
    def write_control(self, data: bytes) -> None: ...
    def poll(self, now: float) -> None: ...  # a link without its own thread advances here
    def close(self) -> None: ...


class FtmsTrainer(TrainerDevice):
    """A trainer behind an FTMS link; subclasses build the link from their options."""

    def __init__(self, options: object, link: FtmsLink, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.link = link
        self.latest = codec.IndoorBikeData()
        self.latest_t = float("-inf")  # [s] device clock of the latest notification
        self.connected = False
        self.in_control = False
        self.counters: Counter[str] = Counter()
        self.responses: list[codec.Response] = []
        self._lock = threading.Lock()  # notifications may arrive on the link's thread
        self._resistance: float | None = None  # [%] last commanded
        self._sent_t = float("-inf")
        link.start(self)

    # ------------------------------------------------------------ link callbacks

    def on_bike_data(self, data: bytes) -> None:
        try:
            sample = codec.decode_bike_data(data)
        except codec.FtmsError as exc:
            self._bad("bike_data", exc)
            return
        with self._lock:
            self.latest, self.latest_t = sample, self.clock()
        self.counters["bike_data"] += 1

    def on_response(self, data: bytes) -> None:
        try:
            response = codec.decode_response(data)
        except codec.FtmsError as exc:
            self._bad("response", exc)
            return
        self.responses = [*self.responses[-63:], response]
        if response.op == codec.OpCode.REQUEST_CONTROL:
            self.in_control = response.ok
        if not response.ok:
            self.counters["refused"] += 1
            log.warning("trainer refused op 0x%02x: %s", response.op, response.result.name)

    def on_connected(self, connected: bool) -> None:
        self.connected = connected
        self.in_control = False
        self.counters["connects" if connected else "disconnects"] += 1
        if connected:  # take control again and restore the last command
            self.link.write_control(codec.request_control())
            self.link.write_control(codec.start_or_resume())
            if self._resistance is not None:
                self._write_resistance(self._resistance)

    def _bad(self, what: str, exc: codec.FtmsError) -> None:
        self.counters[f"bad_{what}"] += 1
        log.debug("dropped a malformed %s: %s", what, exc)

    # ------------------------------------------------------------ TrainerDevice hooks

    def _read(self, now: float) -> tuple[float, float]:
        self.link.poll(now)
        with self._lock:
            sample = self.latest
        return float(sample.power_w or 0), float(sample.cadence_rpm or 0.0)

    def _speed(self, now: float) -> float | None:
        speed_kmh = self.latest.speed_kmh
        return None if speed_kmh is None else speed_kmh * KMH

    def _set_resistance(self, percent: float) -> None:
        now = self.clock()
        last = self._resistance
        self._resistance = percent
        if last is None or abs(percent - last) >= RESISTANCE_STEP or now - self._sent_t > RESEND_S:
            self._sent_t = now
            self._write_resistance(percent)

    def _write_resistance(self, percent: float) -> None:
        if self.connected:
            self.link.write_control(codec.set_target_resistance(percent))
            self.counters["resistance_sent"] += 1

    def _set_target_power(self, power_w: float) -> None:
        if self.connected:
            self.link.write_control(codec.set_target_power(power_w))

    def _set_grade(self, grade_percent: float) -> None:
        if self.connected:
            self.link.write_control(codec.set_simulation(codec.Simulation(0.0, grade_percent)))

    def _close(self) -> None:
        self.link.close()
