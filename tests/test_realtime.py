"""Loop pacing shared by the drive and bike loops: deadlines, period error, no burst catch-up."""

from __future__ import annotations

import time

from carlaverse.realtime import CATCH_UP_PERIODS, Pacer, raise_priority, wait_until


def test_wait_until_never_returns_early() -> None:
    for delay_s in (0.0, 0.0002, 0.002):  # past, inside the spin margin, beyond it
        deadline = time.perf_counter() + delay_s
        wait_until(deadline)
        assert time.perf_counter() >= deadline


def test_the_pacer_measures_each_tick_and_keeps_a_bounded_window() -> None:
    pacer = Pacer(rate_hz=500.0, window=10)
    started = pacer.start()
    for _ in range(25):
        pacer.wait()
        assert pacer.last_error_s >= 0.0  # it never wakes before the deadline
        pacer.advance()
    assert len(pacer.errors) == 10
    assert pacer.max_error_s >= max(pacer.errors)
    # Deadlines advance by one period a tick (a restart after a stall only moves them later).
    assert pacer.next_t >= started + 25 * pacer.period_s - 1e-9
    summary = pacer.summary()
    assert summary["period_error_max_ms"] >= summary["period_error_p99_ms"] >= 0.0


def test_a_stalled_loop_restarts_its_schedule_instead_of_bursting() -> None:
    pacer = Pacer(rate_hz=1000.0)
    pacer.start()
    pacer.wait()
    time.sleep((CATCH_UP_PERIODS + 5) * pacer.period_s)  # suspended for 15 periods
    before = time.perf_counter()
    pacer.advance()
    assert pacer.next_t >= before  # the next deadline is now, not 14 periods in the past


def test_no_priority_change_is_asked_for_priority_zero() -> None:
    assert raise_priority(0) == "unchanged"
