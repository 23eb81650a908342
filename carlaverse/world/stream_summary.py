"""Per-stream statistics: rate, one-way latency, jitter and loss (for `stats`, `demo`, tests).

A world view keeps them per sender as columns (`ego_streams.EgoStreams`); this is their summary.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import msgspec


class StreamSummary(msgspec.Struct, frozen=True):
    samples: int
    rate_hz: float
    latency_p50_ms: float
    latency_p99_ms: float
    jitter_ms: float
    loss: float  # fraction of sequence numbers never seen
    last_seen_s: float  # [s] age of the newest sample when summarised


class Summarised(Protocol):
    """A sender's stream statistics (`ego_streams`), summarised on demand."""

    def summary(self, now: float) -> StreamSummary: ...


def summaries(stats: Mapping[str, Summarised], now: float) -> dict[str, StreamSummary]:
    """Per node, what an observer measured of its poses (`stats` and the launcher show these)."""
    return {node: stream.summary(now) for node, stream in sorted(stats.items())}
