"""Zenoh callbacks that never raise: counted drops, bounded logging.

Zenoh runs subscriber and queryable callbacks on its own threads; an exception escaping one
prints a traceback to stderr and loses the message without a count. Every handler of the
fabric and the authority is therefore wrapped by a `HandlerGuard`: a bad payload is counted
on its key by the handler itself (`support.tally.Tally`), and anything unexpected is counted in
`guard.errors`, logged once per interval as one line, and — for a query — answered with an
error reply, so the asker is never left waiting.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import zenoh

from carlaverse.support.ratelog import RateLimitedLog
from carlaverse.support.tally import Tally


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
                self.failed(name, exc)

        return guarded

    def query(
        self, name: str, handler: Callable[[zenoh.Query], None]
    ) -> Callable[[zenoh.Query], None]:
        def guarded(query: zenoh.Query) -> None:
            try:
                handler(query)
            except Exception as exc:
                self.failed(name, exc)
                reply_err(query, f"the {name} query failed: {type(exc).__name__}")

        return guarded

    def failed(self, name: str, exc: Exception) -> None:
        """Count and log (bounded) a handler's unexpected exception."""
        self.errors.add(name)
        self.log.warning(name, "%s handler failed: %s: %s", name, type(exc).__name__, exc)


def reply_err(query: zenoh.Query, reason: str) -> None:
    """Answer a query with an error; a query already answered or gone is no error of ours."""
    try:
        query.reply_err(reason.encode())
    except Exception as exc:  # the asker left or was answered already: nothing to tell it
        logging.getLogger(__name__).debug("could not answer a query: %s", exc)
