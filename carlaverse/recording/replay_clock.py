"""The session clock of a replay: recorded session time, as the replay plays it.

A replayed pose carries the session time it was published at, and a node or viewer refuses a
pose whose time is far from its own session time (`InterpolationSettings.implausible_s`). So a
replay's `authority/clock` answers the recorded time being played, not the time of day: the
session time of the first sample of a pass (its log time less the recorder's receive offset,
`recording.timeline.receive_offset_ns`) when the pass starts, running at `speed` times real
time from there. Before a pass starts and after the last one ends the clock holds still.

Each pass of a `--loop` is a timeline of its own (`timeline` counts them): its clock starts
over at the recording's start, which the replay authority announces as a new authority, so
that session clocks are allowed to step back to it (`transport.clock.SessionClock.reset`).

Reading takes no lock (the clock queryable answers on Zenoh's thread): the state is one
immutable tuple, replaced whole.
"""

from __future__ import annotations

import time
from collections.abc import Callable


class ReplayClock:
    """Recorded session time [s]: held, or running at `speed` from an anchor."""

    def __init__(self, speed: float = 1.0, local: Callable[[], float] = time.perf_counter) -> None:
        if speed <= 0:
            raise ValueError(f"replay speed must be > 0, got {speed}")
        self.speed = speed
        self._local = local
        self._anchor = (0.0, 0.0, 0.0)  # (local time [s], session time [s], rate [s/s])
        self.timeline = 0  # passes started

    def now(self) -> float:
        """Session time now [s]."""
        local_t, session_t, rate = self._anchor
        return session_t + (self._local() - local_t) * rate if rate else session_t

    @property
    def running(self) -> bool:
        return self._anchor[2] > 0

    def hold(self, session_t: float) -> None:
        """Stand still at `session_t` [s] (before a pass, after the last)."""
        self._anchor = (0.0, session_t, 0.0)

    def start_pass(self, session_t: float, local_t: float) -> None:
        """A pass starts: at local time `local_t` [s] it is recorded time `session_t` [s]."""
        self.timeline += 1
        self._anchor = (local_t, session_t, self.speed)

    def stop(self) -> None:
        """The pass ended: hold at the time reached."""
        self.hold(self.now())
