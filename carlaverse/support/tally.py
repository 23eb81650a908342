"""A counter that several threads may add to: counted drops by channel, errors by handler.

Zenoh runs callbacks on its own threads while the owner reads the counts on its own; every
layer counts what it drops (the transport's callbacks, the world view's update, the
authority), so the counter lives here, below them all.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping


class Tally(Mapping[str, int]):
    """A counter that Zenoh's threads and the owner's thread may all update.

    Reads like a `Counter`: a key never counted reads 0.
    """

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}
        self._lock = threading.Lock()

    def add(self, key: str, n: int = 1) -> None:
        with self._lock:
            self._counts[key] = self._counts.get(key, 0) + n

    def __getitem__(self, key: str) -> int:
        return self._counts.get(key, 0)

    def __contains__(self, key: object) -> bool:
        return key in self._counts

    def __iter__(self) -> Iterator[str]:
        return iter(self.snapshot())

    def __len__(self) -> int:
        return len(self._counts)

    def snapshot(self) -> dict[str, int]:
        """A consistent copy, sorted by key."""
        with self._lock:
            return dict(sorted(self._counts.items()))
