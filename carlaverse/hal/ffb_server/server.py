"""The force-feedback server (paper, section "Force Feedback Server"), in Python.

Every datagram must be one valid 40-byte `FfbCommand`; anything else is counted, logged at a
bounded rate, and applies nothing. Safety watchdog: when no valid packet has arrived for
`watchdog_s`, or the server stops, every force is zeroed at once and that is logged; forces
come back only with the next valid packet.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable

from carlaverse.hal import ffb_packet
from carlaverse.hal.ffb_packet import FfbPacketError
from carlaverse.hal.ffb_server.actuator import ForceActuator
from carlaverse.hal.udp_server import WatchdogUdpServer
from carlaverse.support.ratelog import RateLimitedLog

log = logging.getLogger(__name__)

DEFAULT_WATCHDOG_S = 0.250  # [s] the paper's "predefined timeout"; --watchdog-ms overrides


@dataclasses.dataclass
class FfbServerStats:
    received: int = 0  # datagrams read from the socket and fully handled
    applied: int = 0  # valid commands handed to the actuator
    wrong_size: int = 0
    out_of_range: int = 0
    watchdog_trips: int = 0  # times the watchdog zeroed live forces
    device_errors: int = 0  # actuator calls that failed with OSError

    @property
    def invalid(self) -> int:
        return self.wrong_size + self.out_of_range


class FfbServer(WatchdogUdpServer):
    """UDP -> validated FfbCommand -> actuator, with the safety watchdog."""

    stats: FfbServerStats

    def __init__(
        self,
        actuator: ForceActuator,
        bind: str = "127.0.0.1",
        port: int = ffb_packet.DEFAULT_FFB_PORT,
        *,
        watchdog_s: float = DEFAULT_WATCHDOG_S,
        clock: Callable[[], float] = time.monotonic,
        log_interval_s: float = 1.0,
        poll_interval_s: float = 0.005,
    ) -> None:
        super().__init__(
            bind, port, watchdog_s=watchdog_s, clock=clock, poll_interval_s=poll_interval_s
        )
        self.actuator = actuator
        self.stats = FfbServerStats()
        self._warn = RateLimitedLog(log, clock, log_interval_s)

    def _handle(self, data: bytes, now: float) -> None:
        try:
            command = ffb_packet.decode(data)
        except FfbPacketError as exc:
            self._reject(exc)
            return
        self._accept(now, armed=not command.is_zero())  # a client's own zero needs no watchdog
        if self._device_call(self.actuator.apply, command, "apply"):
            self.stats.applied += 1

    def _reject(self, exc: FfbPacketError) -> None:
        if exc.reason is ffb_packet.FfbPacketReason.WRONG_SIZE:
            self.stats.wrong_size += 1
        else:
            self.stats.out_of_range += 1
        self._warn.warning(exc.reason.value, "FFB packet rejected, nothing applied: %s", exc)

    def _trip(self, now: float, gap_ms: float) -> None:
        self.stats.watchdog_trips += 1
        self._zero(f"watchdog: no valid packet for {gap_ms:.0f} ms")

    def _on_stop(self, now: float) -> None:
        self._zero("server stopping", resumes=False)
        self.actuator.close()

    def _zero(self, why: str, resumes: bool = True) -> None:
        self.armed = False
        self._device_call(self.actuator.zero, None, "zero")
        after = "; they resume with the next valid packet" if resumes else ""
        log.warning("all forces zeroed (%s)%s", why, after)

    def _device_call(self, method: Callable, argument: object, what: str) -> bool:
        try:
            method() if argument is None else method(argument)
        except OSError as exc:
            self.stats.device_errors += 1
            self._warn.log(logging.ERROR, "device", "FFB device failed to %s: %s", what, exc)
            return False
        return True
