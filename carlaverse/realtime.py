"""Fixed-rate loop timing for a node's control process: priority, pacing, period error.

A node's local loop (the drive node at 1 kHz, the bike node at 200 Hz) runs in a process of its
own and ticks on deadlines. `time.sleep` alone overshoots by 50–100 µs on Linux, so the
`Pacer` sleeps until shortly before each deadline and spins the rest of the way. The error
between the deadline and the actual wake-up is measured every tick: the last and worst are
published live, a bounded window of them gives the summary's percentiles.
"""

from __future__ import annotations

import logging
import os
import queue
import time
from array import array
from collections.abc import Iterable
from typing import Any

from carlaverse.support.stats import percentile

log = logging.getLogger(__name__)

SPIN_S = 0.0004  # [s] spin this close to each deadline instead of sleeping
ERROR_WINDOW = 600_000  # ticks of period error kept for the summary (10 min at 1 kHz)
CATCH_UP_PERIODS = 10  # later than this many periods: restart the schedule, do not burst


def raise_priority(priority: int) -> str:
    """Real-time scheduling for this process if allowed, else a better nice value."""
    if priority <= 0:
        return "unchanged"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return f"SCHED_FIFO {priority}"
    except (PermissionError, AttributeError, OSError):
        pass
    try:
        os.nice(-10)
        return "nice -10"
    except (PermissionError, OSError):
        log.warning(
            "loop runs at normal priority: grant CAP_SYS_NICE (or run as root) "
            "for real-time scheduling and tighter loop timing"
        )
        return "normal"


def wait_until(deadline: float) -> None:
    """Sleep, then spin, until `time.perf_counter()` reaches `deadline` [s]."""
    remaining = deadline - time.perf_counter()
    if remaining > SPIN_S:
        time.sleep(remaining - SPIN_S)
    while time.perf_counter() < deadline:
        pass


class Pacer:
    """Ticks at `rate_hz` on `time.perf_counter()` deadlines and measures each wake-up's error."""

    def __init__(self, rate_hz: float, window: int = ERROR_WINDOW) -> None:
        self.period_s = 1.0 / rate_hz
        self.next_t = time.perf_counter()  # [s] the coming deadline
        self.window = window
        self.errors = array("d")  # [s] the first `window` ticks' errors, for percentiles
        self.last_error_s = 0.0
        self.max_error_s = 0.0

    def start(self) -> float:
        """Put the first deadline at now [s] and return it."""
        self.next_t = time.perf_counter()
        return self.next_t

    def wait(self) -> None:
        """Block until the coming deadline and record how late the wake-up was."""
        wait_until(self.next_t)
        error = time.perf_counter() - self.next_t
        if len(self.errors) < self.window:
            self.errors.append(error)
        self.last_error_s = error
        self.max_error_s = max(self.max_error_s, error)

    def advance(self) -> None:
        """Move to the next deadline; after a suspension or starvation, restart from now."""
        self.next_t += self.period_s
        if time.perf_counter() - self.next_t > CATCH_UP_PERIODS * self.period_s:
            self.next_t = time.perf_counter()

    def summary(self) -> dict[str, float]:
        """Period error p50 / p99 / max [ms] for the loop's report."""
        errors = list(self.errors)
        return {
            "period_error_p50_ms": round(percentile(errors, 0.5) * 1e3, 4),
            "period_error_p99_ms": round(percentile(errors, 0.99) * 1e3, 4),
            "period_error_max_ms": round(self.max_error_s * 1e3, 4),
        }


def stop_loop_process(
    process: Any, stop: Any, results: Any, blocks: Iterable[Any], what: str
) -> Any:
    """Stop a node's loop process: signal it, take its final report, reap it, free its blocks.

    Returns the report the loop put on `results`, or None if it did not report in time (logged).
    The blocks are the node's shared-memory blocks (closed here, as their owner).
    """
    stop.set()
    try:
        summary = results.get(timeout=10)
    except queue.Empty:
        summary = None
        log.error("the %s did not report", what)
    process.join(timeout=5)
    if process.is_alive():
        process.kill()
    for block in blocks:
        if block is not None:
            block.close()
    return summary
