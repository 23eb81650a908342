"""A connected, non-blocking UDP sender for the FFB and motion clients.

A send never blocks the control loop and never raises into it: a full socket buffer
(`BlockingIOError`) or an ICMP port-unreachable from a server that is not running yet
(`ConnectionRefusedError` on the next send) is counted and logged at a bounded rate. The
next packet supersedes the lost one, as for any high-rate state.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable

from carlaverse.hal.errors import DeviceError
from carlaverse.support.ratelog import RateLimitedLog

log = logging.getLogger(__name__)


class UdpSender:
    def __init__(self, host: str, port: int, clock: Callable[[], float], what: str) -> None:
        self.what = what
        self.sent = 0
        self.dropped = 0  # buffer full
        self.errors = 0  # refused or unreachable
        self._warn = RateLimitedLog(log, clock)
        try:
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.sock.setblocking(False)
            self.sock.connect((host, port))  # connect once: cheaper sends, errors surface
        except OSError as exc:
            raise DeviceError(f"cannot reach {what} at {host}:{port}: {exc}") from exc

    def send(self, payload: bytes) -> bool:
        """Send one datagram; False (counted, logged) when it could not be sent."""
        try:
            self.sock.send(payload)
        except BlockingIOError:
            self.dropped += 1
            self._warn.warning("full", "%s: send buffer full, packet dropped", self.what)
            return False
        except OSError as exc:
            self.errors += 1
            self._warn.warning("error", "%s: send failed (%s); is it running?", self.what, exc)
            return False
        self.sent += 1
        return True

    def close(self) -> None:
        self.sock.close()
