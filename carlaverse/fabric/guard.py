"""Zenoh callbacks that never raise: counted drops, thread-safe tallies, bounded logging.

Zenoh runs subscriber and queryable callbacks on its own threads; an exception escaping one
prints a traceback to stderr and loses the message without a count. Every handler of the
fabric and the authority is therefore wrapped by a `HandlerGuard`: a bad payload is counted
on its key by the handler itself (`Tally`), and anything unexpected is counted in
`guard.errors`, logged once per interval as one line, and — for a query — answered with an
error reply, so the asker is never left waiting.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator, Mapping

import zenoh

from carlaverse.support.ratelog import RateLimitedLog


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


class HandlerGuard:
    """Wraps Zenoh callbacks so that no exception ever escapes into Zenoh."""

    def __init__(self, logger: logging.Logger, log_interval_s: float = 5.0) -> None:
        self.errors = Tally()
        self.log = RateLimitedLog(logger, time.monotonic, log_interval_s)  # for the handlers too

    def sample(
        self, name: str, handler: Callable[[zenoh.Sample], None]
    ) -> Callable[[zenoh.Sample], None]:
        def guarded(sample: zenoh.Sample) -> None:
            try:
                handler(sample)
            except Exception as exc:  # a bug or a case not foreseen: count, never raise
                self._failed(name, exc)

        return guarded

    def query(
        self, name: str, handler: Callable[[zenoh.Query], None]
    ) -> Callable[[zenoh.Query], None]:
        def guarded(query: zenoh.Query) -> None:
            try:
                handler(query)
            except Exception as exc:
                self._failed(name, exc)
                reply_err(query, f"the {name} query failed: {type(exc).__name__}")

        return guarded

    def _failed(self, name: str, exc: Exception) -> None:
        self.errors.add(name)
        self.log.warning(name, "%s handler failed: %s: %s", name, type(exc).__name__, exc)


def reply_err(query: zenoh.Query, reason: str) -> None:
    """Answer a query with an error; a query already answered or gone is no error of ours."""
    try:
        query.reply_err(reason.encode())
    except Exception as exc:  # the asker left or was answered already: nothing to tell it
        logging.getLogger(__name__).debug("could not answer a query: %s", exc)
