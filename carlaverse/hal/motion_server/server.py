"""The motion-platform server (paper, section "Motion Platform Server"), in Python.

Each datagram should be one 21-byte FRAME_UPDATE. A short one is the paper's safety case: a
warning is logged and the data ignored. Longer packets, unknown command ids and values that
are not finite or break `MotionLimits` are counted and ignored too. Watchdog: when frames stop
for `watchdog_s`, or the server ends, the platform goes to neutral once, and that is logged.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable

from carlaverse.hal import motion_packet
from carlaverse.hal.motion_packet import (
    DEFAULT_LIMITS,
    MotionLimits,
    MotionPacketError,
    MotionPacketReason,
)
from carlaverse.hal.motion_server.platform import MotionPlatform
from carlaverse.hal.udp_server import WatchdogUdpServer
from carlaverse.support.ratelog import RateLimitedLog

log = logging.getLogger(__name__)

DEFAULT_WATCHDOG_S = 0.250  # [s]

COUNTER_BY_REASON = {
    MotionPacketReason.SHORT: "short",
    MotionPacketReason.LONG: "long",
    MotionPacketReason.UNKNOWN_COMMAND: "unknown_command",
    MotionPacketReason.NOT_FINITE: "invalid_value",
    MotionPacketReason.OUT_OF_RANGE: "invalid_value",
}


@dataclasses.dataclass
class MotionServerStats:
    received: int = 0  # datagrams read from the socket and fully handled
    frames: int = 0  # valid frames handed to the platform
    short: int = 0
    long: int = 0
    unknown_command: int = 0
    invalid_value: int = 0  # not finite or over a limit
    neutral_events: int = 0  # watchdog trips (stop not included)
    device_errors: int = 0

    @property
    def ignored(self) -> int:
        return self.short + self.long + self.unknown_command + self.invalid_value


class MotionServer(WatchdogUdpServer):
    """UDP -> validated MotionFrame -> platform, with the neutral-on-silence watchdog."""

    stats: MotionServerStats

    def __init__(
        self,
        platform: MotionPlatform,
        bind: str = "127.0.0.1",
        port: int = motion_packet.DEFAULT_MOTION_PORT,
        *,
        limits: MotionLimits = DEFAULT_LIMITS,
        watchdog_s: float = DEFAULT_WATCHDOG_S,
        clock: Callable[[], float] = time.monotonic,
        log_interval_s: float = 1.0,
        poll_interval_s: float = 0.005,
    ) -> None:
        super().__init__(
            bind, port, watchdog_s=watchdog_s, clock=clock, poll_interval_s=poll_interval_s
        )
        self.platform = platform
        self.limits = limits
        self.stats = MotionServerStats()
        self._warn = RateLimitedLog(log, clock, log_interval_s)

    def _handle(self, data: bytes, now: float) -> None:
        try:
            frame = motion_packet.decode(data, self.limits)
        except MotionPacketError as exc:
            counter = COUNTER_BY_REASON[exc.reason]
            setattr(self.stats, counter, getattr(self.stats, counter) + 1)
            self._warn.warning(counter, "motion packet ignored: %s", exc)
            return
        self._accept(now)
        if self._device_call(self.platform.apply, frame, now):
            self.stats.frames += 1

    @property
    def moving(self) -> bool:
        """True from a valid frame until the platform goes neutral."""
        return self.armed

    def _trip(self, now: float, gap_ms: float) -> None:
        self.stats.neutral_events += 1
        self._neutral(now, f"watchdog: no frame for {gap_ms:.0f} ms")

    def _on_stop(self, now: float) -> None:
        self._neutral(now, "server stopping")
        self.platform.close()

    def _neutral(self, now: float, why: str) -> None:
        self.armed = False
        self._device_call(self.platform.neutral, None, now)
        log.warning("motion platform to neutral (%s)", why)

    def _device_call(self, method: Callable, frame: object, now: float) -> bool:
        try:
            method(now) if frame is None else method(frame, now)
        except OSError as exc:
            self.stats.device_errors += 1
            self._warn.log(logging.ERROR, "device", "motion platform failed: %s", exc)
            return False
        return True
