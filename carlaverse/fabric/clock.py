"""Clocks: a monotonic source, a manual one for tests, and the session-clock estimator.

The authority's clock is the session's (DESIGN §4). A node measures the offset between its own
monotonic clock and the session clock by querying `authority/clock`: for each exchange it
knows when it asked (t0) and heard back (t1) on its own clock and what the authority said (ts);
assuming symmetric paths, offset = ts − (t0 + t1) / 2, with an error bound of RTT / 2. The
sample with the smallest RTT in a sliding window has the tightest bound, so that is the one
kept (NTP's clock filter does the same).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Protocol


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on a monotonic timeline."""
        ...


class MonotonicClock:
    def now(self) -> float:
        return time.monotonic()


class ManualClock:
    """A clock tests move by hand."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = start
        self._lock = threading.Lock()

    def now(self) -> float:
        return self._t

    def advance(self, dt: float) -> float:
        with self._lock:
            self._t += dt
            return self._t

    def set(self, t: float) -> None:
        with self._lock:
            self._t = t


class WallAlignedClock:
    """Monotonic time shifted to read as Unix time at construction: the authority's clock.

    It never jumps with NTP adjustments, yet a restarted authority on the same host continues
    the same timeline to within clock-sync precision, and recordings carry absolute times.
    """

    def __init__(self) -> None:
        self._offset = time.time() - time.monotonic()

    def now(self) -> float:
        return time.monotonic() + self._offset


class SessionClock:
    """Session time for a node: its local clock plus the estimated offset to the authority."""

    def __init__(self, local: Clock, window: int = 16) -> None:
        self.local = local
        # Until the first exchange, assume the hosts' wall clocks agree (NTP-synced lab hosts):
        # far better than zero, and replaced by a measurement within a second of joining.
        self._offset = time.time() - time.monotonic() if isinstance(local, MonotonicClock) else 0.0
        self._samples: deque[tuple[float, float]] = deque(maxlen=window)  # (rtt, offset)
        self.synced = False

    def now(self) -> float:
        return self.local.now() + self._offset

    @property
    def offset(self) -> float:
        return self._offset

    @property
    def uncertainty_s(self) -> float:
        """Half the best RTT in the window: the bound on the offset error."""
        return min(r for r, _ in self._samples) / 2 if self._samples else float("inf")

    def add_exchange(self, t0: float, ts: float, t1: float) -> None:
        """Record one clock query: sent at local t0, answered with session ts, heard at t1."""
        rtt = t1 - t0
        if rtt < 0:
            return
        self._samples.append((rtt, ts - (t0 + t1) / 2))
        self._offset = min(self._samples)[1]
        self.synced = True

    def reset(self) -> None:
        """Forget the window (the authority restarted and may have a new timeline)."""
        self._samples.clear()
