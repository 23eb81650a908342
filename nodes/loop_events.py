"""The loop side of a node's event queue: take what waits, never wait (the tick must not)."""

from __future__ import annotations

import queue
from collections.abc import Iterator
from typing import Any


def drain(events: Any) -> Iterator[Any]:
    """Every event waiting on the queue now, without blocking (the loop's tick must not wait)."""
    while True:
        try:
            yield events.get_nowait()
        except queue.Empty:
            return
