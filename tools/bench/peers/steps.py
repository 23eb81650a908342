"""The steps of the fabric's pose callback, each timed alone in this process.

`Inbound._on_pose` reads the session clock, takes the sender's id from the key (a cached
parse), decodes and checks the 64-byte pose, and appends it to the world view's inbox.
Timed here one by one (the median of repeated batches, so a descheduled batch does not
count) with the fabric's own functions, to say which of them the callback's time is made
of. A warm loop like this is the best case: the callback, run 50 times a second, meets cold
caches.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

BATCH = 2000  # calls per timed batch
BATCHES = 15  # batches; their median is reported


def per_call_s(call: Callable[[], object]) -> float:
    """Median over batches of the time one call takes [s]."""
    batches = []
    for _ in range(BATCHES):
        start = time.perf_counter()
        for _ in range(BATCH):
            call()
        batches.append((time.perf_counter() - start) / BATCH)
    return statistics.median(batches)


def callback_steps() -> list[tuple[str, float]]:
    """(step, seconds per call) for each step of the pose callback."""
    from carlaverse import messages as m
    from carlaverse.fabric.clock import MonotonicClock, SessionClock
    from carlaverse.fabric.remote_actor import InterpolationSettings
    from carlaverse.fabric.world_view import WorldView
    from carlaverse.keys import Keys, parse_cached

    key = Keys("bench").pose("tx", "t0_0")
    payload = m.encode_pose(m.Pose(1, time.monotonic(), 0.0, 0.0, vx=14.0))
    pose = m.POSE.decode(payload)
    clock = SessionClock(MonotonicClock())
    world = WorldView("rx0", InterpolationSettings())
    steps: list[tuple[str, Callable[[], object]]] = [
        ("session clock (`SessionClock.now`)", clock.now),
        ("sender from the key (`keys.parse_cached`)", lambda: parse_cached(key).node_id),
        ("decode and check (`decode_pose`)", lambda: m.decode_pose(payload)),
        ("hand-over (`WorldView.push_pose`)", lambda: world.push_pose("tx", pose, 0.0)),
    ]
    timed = []
    for name, call in steps:
        timed.append((name, per_call_s(call)))
        world.inbox.clear()
    return timed


def steps_line() -> str:
    steps = callback_steps()
    total = sum(s for _, s in steps)
    parts = "; ".join(f"{name} {s * 1e6:.1f} µs" for name, s in steps)
    return (
        f"- The pose callback's steps timed alone in a warm loop (median of {BATCHES} batches "
        f"of {BATCH} calls): {parts}; together {total * 1e6:.1f} µs."
    )
