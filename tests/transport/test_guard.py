from __future__ import annotations

import logging
import threading

import pytest

from carlaverse.support.tally import Tally
from carlaverse.transport.guard import HandlerGuard


class FakeQuery:
    def __init__(self) -> None:
        self.errors: list[bytes] = []

    def reply_err(self, payload: bytes) -> None:
        self.errors.append(payload)


def test_a_failing_handler_is_counted_logged_once_and_never_raises(
    caplog: pytest.LogCaptureFixture,
) -> None:
    guard = HandlerGuard(logging.getLogger("test.guard"), log_interval_s=60.0)

    def broken(_: object) -> None:
        raise RecursionError("deep")

    handler = guard.sample("events", broken)
    with caplog.at_level(logging.WARNING):
        for _ in range(100):
            handler(object())  # type: ignore[arg-type]
    assert guard.errors["events"] == 100
    lines = [r for r in caplog.records if "events handler failed" in r.getMessage()]
    assert len(lines) == 1 and lines[0].exc_info is None  # one line, no traceback


def test_a_failing_query_handler_still_answers_with_an_error() -> None:
    guard = HandlerGuard(logging.getLogger("test.guard"))
    query = FakeQuery()

    def broken(_: object) -> None:
        raise KeyError("x")

    guard.query("join", broken)(query)  # type: ignore[arg-type]
    assert guard.errors["join"] == 1
    assert query.errors == [b"the join query failed: KeyError"]


def test_tally_counts_exactly_from_many_threads() -> None:
    tally = Tally()

    def hammer() -> None:
        for _ in range(20_000):
            tally.add("pose")

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert tally["pose"] == 80_000 and tally["never"] == 0
    assert dict(tally) == {"pose": 80_000} == tally.snapshot()
