"""Test plumbing for the hardware layer: a hand-driven clock and UDP senders."""

from __future__ import annotations

import socket
import threading


class ManualClock:
    """A clock that moves only when the test says so (trio's MockClock, in miniature)."""

    def __init__(self, start: float = 1000.0) -> None:
        self.t = start
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            return self.t

    def advance(self, seconds: float) -> None:
        with self._lock:
            self.t += seconds


class Sender:
    """A plain UDP socket aimed at one server."""

    def __init__(self, address: tuple[str, int]) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.address = address

    def send(self, payload: bytes) -> None:
        self.sock.sendto(payload, self.address)

    def close(self) -> None:
        self.sock.close()
