"""A recording's series read back at any time, for its OSI export: an actor's samples
(`ActorTrack`) and a series of changes (`Latest`: signals, weather, vehicle lights).

The one pass over the recording that gathers them is `recording/recorded_world.py`, shared
with the analysis. An actor's acceleration is what its poses carry; where they carry none
(all zero: scripted nodes, NPCs) it is the derivative of its recorded velocity.
"""

from __future__ import annotations

import bisect
import math
from typing import Generic, TypeVar

import numpy as np

from carlaverse.recording.recorded_world import COLUMN

T = TypeVar("T")
ANGLES = [COLUMN["roll"], COLUMN["pitch"], COLUMN["yaw"]]


class ActorTrack:
    """One actor's samples, with accelerations filled in where none were carried."""

    def __init__(self, rows: np.ndarray, max_gap_s: float) -> None:
        """`rows`: `RecordedWorld.rows`, sorted by time and one per instant (changed here)."""
        rows[:, ANGLES] = np.unwrap(rows[:, ANGLES], axis=0)  # interpolate the short way
        self.max_gap_s = max_gap_s
        self.t = rows[:, 0]
        if not rows[:, COLUMN["ax"] :].any():  # no acceleration carried: differentiate velocity
            rows[:, COLUMN["ax"] :] = self._derivative(rows[:, COLUMN["vx"] : COLUMN["vz"] + 1])
        self.rows = rows

    def _derivative(self, values: np.ndarray) -> np.ndarray:
        """d values / dt within each stretch without a gap (0 for a lone sample)."""
        out = np.zeros_like(values)
        cuts = np.flatnonzero(np.diff(self.t) > self.max_gap_s) + 1
        for piece in np.split(np.arange(len(self.t)), cuts):
            if len(piece) > 1:
                out[piece] = np.gradient(values[piece], self.t[piece], axis=0)
        return out

    def at(self, t: float) -> np.ndarray | None:
        """The row interpolated at session time `t`, or None where the actor is absent."""
        if t < self.t[0] or t > self.t[-1]:
            return None
        after = min(max(1, bisect.bisect_left(self.t, t)), len(self.t) - 1)
        if len(self.t) == 1:
            return self.rows[0] if math.isclose(t, self.t[0]) else None
        t0, t1 = self.t[after - 1], self.t[after]
        if t1 - t0 > self.max_gap_s:
            return None
        w = (t - t0) / (t1 - t0)
        return self.rows[after - 1] * (1 - w) + self.rows[after] * w


class Latest(Generic[T]):
    """What a series of changes says at time t: its newest value at or before t."""

    def __init__(self, changes: list[tuple[float, T]]) -> None:
        ordered = sorted(changes, key=lambda change: change[0])  # stable: receive order kept
        self.times = [t for t, _ in ordered]
        self.values = [value for _, value in ordered]

    def at(self, t: float) -> T | None:
        k = bisect.bisect_right(self.times, t) - 1
        return self.values[k] if k >= 0 else None
