"""The inbox between Zenoh callbacks and the render loop: latest state, plus events.

Viewing must never slow the session, so a callback does O(1) work under a short lock: it
keeps the newest payload per key (state supersedes state) and appends events — which must
not be lost — to a bounded deque. The render loop takes everything at its own pace; if it
falls behind, it sees fewer intermediate states (dropped frames), never a blocked fabric.
"""

from __future__ import annotations

import threading
from collections import Counter
from dataclasses import dataclass, field

from carlaverse.keys import KeySpaceError, ParsedKey, parse_cached

# Channels whose every sample matters: discrete events and on-change state.
EVENT_CHANNELS = {("world", "events"), ("world", "lights"), ("impulse", ""), ("ego", "state")}
EVENTS_MAX = 4096


@dataclass(frozen=True, slots=True)
class Sample:
    key: ParsedKey
    payload: bytes
    rx_t: float  # [s] local receive time (or log time, when playing a recording)
    kind: str = "put"  # put | delete


@dataclass(slots=True)
class Batch:
    """What the render loop takes at once: newest states, all events, counts since last take."""

    latest: dict[str, Sample] = field(default_factory=dict)
    events: list[Sample] = field(default_factory=list)
    counts: Counter[ParsedKey] = field(default_factory=Counter)  # every sample, kept or not
    dropped_events: int = 0

    def samples(self) -> list[Sample]:
        """Events and states merged in receive order."""
        return sorted([*self.events, *self.latest.values()], key=lambda s: s.rx_t)


class SampleStore:
    """Thread-safe; `offer` from any thread, `take` from the render loop."""

    def __init__(self, events_max: int = EVENTS_MAX) -> None:
        self._lock = threading.Lock()
        self._events_max = events_max
        self._batch = Batch()
        self.unknown_keys = 0  # samples on keys outside the key space

    def offer(self, key: str, payload: bytes, rx_t: float, kind: str = "put") -> None:
        parsed = self._parse(key)
        if parsed is None:
            return
        sample = Sample(parsed, payload, rx_t, kind)
        with self._lock:
            batch = self._batch
            batch.counts[parsed] += 1
            if (parsed.area, parsed.channel) in EVENT_CHANNELS or parsed.area == "node":
                if len(batch.events) >= self._events_max:
                    batch.dropped_events += 1
                    return
                batch.events.append(sample)
            else:
                batch.latest[key] = sample

    def take(self) -> Batch:
        with self._lock:
            batch, self._batch = self._batch, Batch()
        return batch

    def _parse(self, key: str) -> ParsedKey | None:
        # The shared bounded cache: a cache of its own kept every key ever seen, so a peer
        # inventing keys grew the viewer without end.
        try:
            return parse_cached(key)
        except KeySpaceError:
            self.unknown_keys += 1
            return None
