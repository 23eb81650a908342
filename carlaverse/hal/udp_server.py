"""A UDP receive loop that never blocks past its next deadline, shared by the FFB and motion
servers.

The loop waits in `select` with a timeout no longer than the next watchdog deadline (and at
most `poll_interval_s`), drains every queued datagram, then lets the subclass run its timers.
A self-pipe wakes it at once on `stop()`, so shutdown (and the zeroing it implies) does not
wait out a timeout. The same object runs in the calling thread (`serve_forever`, for the CLI)
or in a background thread (`start`/`stop`, for tests and embedding).
"""

from __future__ import annotations

import contextlib
import logging
import select
import socket
import threading
import time
from collections.abc import Callable

log = logging.getLogger(__name__)

MAX_DATAGRAM = 2048  # [bytes] larger than any valid packet, so oversize ones show as such
DRAIN_LIMIT = 256  # datagrams handled per wake-up before the timers get a turn


class UdpServer:
    """Base class: bind, receive, tick; subclasses implement the three hooks."""

    def __init__(
        self,
        bind: str = "127.0.0.1",
        port: int = 0,
        *,
        clock: Callable[[], float] = time.monotonic,
        poll_interval_s: float = 0.005,
        receive_buffer_bytes: int = 1 << 20,
    ) -> None:
        self.clock = clock
        self.poll_interval_s = poll_interval_s  # [s] longest wait between timer checks
        self.ticks = 0  # loop iterations, so tests can wait for "the loop has looked"
        self._sock = self._bind(bind, port, receive_buffer_bytes)
        self._wake_r, self._wake_w = socket.socketpair()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self._served = False

    @staticmethod
    def _bind(bind: str, port: int, receive_buffer_bytes: int) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer_bytes)
            sock.bind((bind, port))
        except OSError:
            sock.close()
            raise
        sock.setblocking(False)
        return sock

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port); port 0 at construction picks a free one."""
        return self._sock.getsockname()

    # ------------------------------------------------------------------ hooks
    def _on_datagram(self, data: bytes, now: float) -> None:
        raise NotImplementedError

    def _on_tick(self, now: float) -> None:
        """Run timers (the watchdog); called after every wake-up."""

    def _next_deadline(self, now: float) -> float | None:
        """Clock time the loop must wake by, or None."""
        return None

    def _on_stop(self, now: float) -> None:
        """Make the device safe; called once when the loop ends, however it ends."""

    # ------------------------------------------------------------------ loop
    def serve_forever(self) -> None:
        """Run until `stop()`; always ends through `_on_stop`."""
        self._served = True
        try:
            while not self._stopping.is_set():
                self._wait_and_drain()
                self._on_tick(self.clock())
                self.ticks += 1
        finally:
            self._on_stop(self.clock())
            self._sock.close()
            self._wake_r.close()

    def _wait_and_drain(self) -> None:
        readable, _, _ = select.select([self._sock, self._wake_r], [], [], self._timeout())
        if self._sock in readable:
            self._drain()

    def _timeout(self) -> float:
        now = self.clock()
        deadline = self._next_deadline(now)
        if deadline is None:
            return self.poll_interval_s
        return min(self.poll_interval_s, max(0.0, deadline - now))

    def _drain(self) -> None:
        for _ in range(DRAIN_LIMIT):
            try:
                data = self._sock.recv(MAX_DATAGRAM)
            except BlockingIOError:
                return
            except OSError as exc:  # e.g. ICMP errors surfacing on Windows; not ours to die of
                log.warning("UDP receive failed on %s: %s", self.address, exc)
                return
            self._on_datagram(data, self.clock())

    # ------------------------------------------------------------------ thread
    def start(self) -> UdpServer:
        """Serve in a daemon thread; returns self."""
        self._thread = threading.Thread(
            target=self.serve_forever, name=type(self).__name__, daemon=True
        )
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        """Ask the loop to end, wake it, and join its thread if it has one."""
        self._stopping.set()
        with contextlib.suppress(OSError):
            self._wake_w.send(b"x")
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
        if not self._served:  # never ran: nothing else will close the sockets
            self._sock.close()
            self._wake_r.close()
        with contextlib.suppress(OSError):
            self._wake_w.close()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self) -> UdpServer:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()


class WatchdogUdpServer(UdpServer):
    """A UdpServer whose device is made safe when valid input stops for `watchdog_s`.

    The FFB and motion servers differ in what "safe" means (zero every force, platform to
    neutral), not in when: subclasses arm the watchdog on valid input and implement `_trip`.
    """

    stats: object  # the subclass's counters; must have `received`

    def __init__(
        self, bind: str, port: int, *, watchdog_s: float, clock: Callable[[], float],
        poll_interval_s: float,
    ) -> None:  # fmt: skip
        super().__init__(bind, port, clock=clock, poll_interval_s=poll_interval_s)
        self.watchdog_s = watchdog_s  # [s]
        self.armed = False  # the device is doing something the watchdog must undo
        self.last_valid_t: float | None = None  # [s] server clock of the last valid input

    def _on_datagram(self, data: bytes, now: float) -> None:
        try:
            self._handle(data, now)
        finally:
            self.stats.received += 1  # type: ignore[attr-defined]  # counted once handled

    def _handle(self, data: bytes, now: float) -> None:
        raise NotImplementedError

    def _accept(self, now: float, armed: bool = True) -> None:
        """Valid input arrived: restart the watchdog (or disarm it for an explicit rest)."""
        self.last_valid_t = now
        self.armed = armed

    def _next_deadline(self, now: float) -> float | None:
        if not self.armed or self.last_valid_t is None:
            return None
        return self.last_valid_t + self.watchdog_s

    def _on_tick(self, now: float) -> None:
        deadline = self._next_deadline(now)
        if deadline is not None and now >= deadline:
            self._trip(now, (now - (self.last_valid_t or now)) * 1000)

    def _trip(self, now: float, gap_ms: float) -> None:
        """Make the device safe after `gap_ms` of silence; disarm."""
        raise NotImplementedError
