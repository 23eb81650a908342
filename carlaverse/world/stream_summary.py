"""Per-stream statistics: rate, one-way latency, jitter and loss (for `stats`, `demo`, tests).

A world view keeps them per sender as columns (`ego_streams.EgoStreams`); this is their summary.
"""

from __future__ import annotations

import msgspec


class StreamSummary(msgspec.Struct, frozen=True):
    samples: int
    rate_hz: float
    latency_p50_ms: float
    latency_p99_ms: float
    jitter_ms: float
    loss: float  # fraction of sequence numbers never seen
    last_seen_s: float  # [s] age of the newest sample when summarised
