"""Per-stream statistics: rate, one-way latency, jitter and loss (for `stats`, `demo`, tests)."""

from __future__ import annotations

from collections import deque

import msgspec


class StreamSummary(msgspec.Struct, frozen=True):
    samples: int
    rate_hz: float
    latency_p50_ms: float
    latency_p99_ms: float
    jitter_ms: float
    loss: float  # fraction of sequence numbers never seen
    last_seen_s: float  # [s] age of the newest sample when summarised


def percentile(values: list[float], q: float) -> float:
    """The q-quantile (0..1) by nearest rank; NaN for no values."""
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


class StreamStats:
    """Accumulates one sender's samples as a receiver sees them."""

    def __init__(self, window: int = 4096) -> None:
        self._latency: deque[float] = deque(maxlen=window)
        self._rx: deque[float] = deque(maxlen=window)
        self.count = 0
        self._first_seq: int | None = None
        self._max_seq = -1
        self._jitter = 0.0  # RFC 3550 interarrival jitter estimate [s]
        self._last_transit: float | None = None
        self.last_rx_t = float("nan")

    def add(self, seq: int, sent_t: float, rx_t: float) -> None:
        # Once per pose of every sender a node hears: plain comparisons, no helper calls.
        transit = rx_t - sent_t
        last = self._last_transit
        if last is not None:
            self._jitter += (abs(transit - last) - self._jitter) * 0.0625  # gain 1/16
        self._last_transit = transit
        self._latency.append(transit)
        self._rx.append(rx_t)
        self.count += 1
        if self._first_seq is None:
            self._first_seq = seq
        if seq > self._max_seq:
            self._max_seq = seq
        self.last_rx_t = rx_t

    def summary(self, now: float) -> StreamSummary:
        lat = list(self._latency)
        span = self._rx[-1] - self._rx[0] if len(self._rx) > 1 else 0.0
        rate = (len(self._rx) - 1) / span if span > 0 else 0.0
        expected = self._max_seq - self._first_seq + 1 if self._first_seq is not None else 0
        loss = max(0.0, 1 - self.count / expected) if expected > 0 else 0.0
        return StreamSummary(
            samples=self.count,
            rate_hz=round(rate, 2),
            latency_p50_ms=round(percentile(lat, 0.5) * 1e3, 3),
            latency_p99_ms=round(percentile(lat, 0.99) * 1e3, 3),
            jitter_ms=round(self._jitter * 1e3, 3),
            loss=round(loss, 4),
            last_seen_s=round(now - self.last_rx_t, 3),
        )
