"""The steps of the fabric's pose callback, each timed alone in this process.

`Inbound._on_pose` reads the session clock, takes the sender's id from the key (a cached
parse), and appends the pose's 64 bytes to the world view's inbox (the view checks and
decodes them in its update, on the node's loop).
Timed here one by one with the fabric's own functions, to say which of them the callback's
time is made of, twice: in a warm loop (the median of repeated batches, so a descheduled
batch does not count), the best case; and one call after each 20 ms of sleep, as the callback
runs at 50 Hz. A core idle for 20 ms runs the same Python several times slower (cold caches,
and on a virtual machine a virtual CPU woken from its halt), which is what the callback
pays on every pose of a 50 Hz stream.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

BATCH = 2000  # calls per timed batch
BATCHES = 15  # batches; their median is reported
SPACING_S = 0.02  # [s] idle before each spaced call: one pose period at 50 Hz
SPACED_CALLS = 100  # spaced calls per step; their median is reported


def per_call_s(call: Callable[[], object]) -> float:
    """Median over batches of the time one call takes [s]."""
    batches = []
    for _ in range(BATCHES):
        start = time.perf_counter()
        for _ in range(BATCH):
            call()
        batches.append((time.perf_counter() - start) / BATCH)
    return statistics.median(batches)


def spaced_call_s(call: Callable[[], object]) -> float:
    """Median time of one call made after `SPACING_S` of sleep [s]."""
    times = []
    for _ in range(SPACED_CALLS):
        time.sleep(SPACING_S)
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def callback_steps() -> list[tuple[str, float, float]]:
    """(step, seconds per call in a warm loop, seconds per call after 20 ms idle) for each
    step of the pose callback."""
    from carlaverse import messages as m
    from carlaverse.keys import Keys, parse_cached
    from carlaverse.transport.clock import MonotonicClock, SessionClock
    from carlaverse.world.remote_actor import InterpolationSettings
    from carlaverse.world.world_view import WorldView

    key = Keys("bench").pose("tx", "t0_0")
    payload = m.encode_pose(m.Pose(1, time.monotonic(), 0.0, 0.0, vx=14.0))
    clock = SessionClock(MonotonicClock())
    world = WorldView("rx0", InterpolationSettings())
    steps: list[tuple[str, Callable[[], object]]] = [
        ("session clock (`SessionClock.now`)", clock.now),
        ("sender from the key (`keys.parse_cached`)", lambda: parse_cached(key).node_id),
        ("hand-over (`WorldIntake.pose`)", lambda: world.intake.pose("tx", payload, 0.0)),
    ]
    timed = []
    for name, call in steps:
        warm = per_call_s(call)
        world.intake.inbox.clear()
        timed.append((name, warm, spaced_call_s(call)))
        world.intake.inbox.clear()
    return timed


def steps_line() -> str:
    steps = callback_steps()
    warm, spaced = (sum(step[k] for step in steps) for k in (1, 2))
    parts = "; ".join(f"{name} {w * 1e6:.1f} / {s * 1e6:.1f} µs" for name, w, s in steps)
    return (
        f"- The pose callback's steps timed alone, in a warm loop (median of {BATCHES} batches "
        f"of {BATCH} calls) / one call after each {SPACING_S * 1e3:g} ms idle, as at 50 Hz "
        f"(median of {SPACED_CALLS}): {parts}; together {warm * 1e6:.1f} / "
        f"{spaced * 1e6:.1f} µs."
    )
