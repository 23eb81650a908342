"""When each listener's audio scene is due: listeners dealt into phase groups over the ticks.

Every listener gets a scene each audio period (1 / `rate_hz`). Built in one tick, the scenes
of 256 listeners make that tick the slowest of the period, and the authority's budget is
its tick's p99. So listeners are dealt into G phase groups, group g due g·period/G after
group 0, with G at most the authority ticks in one period and at most one group served per
tick: a tick builds at most ceil(L / G) scenes, and each listener still hears every period
(± one tick, as before). Fewer than 2 × GROUP_MIN_LISTENERS listeners stay one group: for a
handful, splitting would only pay the fixed cost of an audio instant (every actor's engine
and tyres) more often.

A listener keeps its group while it stays; a newcomer joins the smallest group. Only when
sizes differ by more than one (listeners left, or G changed) is the newest member of the
largest group moved to the smallest: that listener's next interval is off by up to half a
period, once.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from collections.abc import Sequence

import numpy as np

GROUP_MIN_LISTENERS = 16  # a group holds at least this many (one group below twice this)
DEFAULT_TICK_HZ = 50.0  # [Hz] the authority's default tick, until the calls show theirs
TICK_GAPS_KEPT = 15  # the tick interval is the median of the last gaps between calls


class PhaseGroups:
    """Which listeners build their scene at each tick; call `due` once per authority tick."""

    def __init__(self, rate_hz: float, tick_hz: float = DEFAULT_TICK_HZ) -> None:
        self._period_s = 1.0 / rate_hz
        self._gaps_s: deque[float] = deque([1.0 / tick_hz], maxlen=TICK_GAPS_KEPT)
        self._last_t: float | None = None
        self._group: dict[str, int] = {}  # listener id -> its group, in order of arrival
        self._next_t = [-math.inf]  # [s] when each group is due next
        self._dealt: list[str] = []  # the listeners as last dealt, in their order
        self._dealt_groups = np.zeros(0, dtype=np.intp)  # and the group of each

    @property
    def groups(self) -> int:
        return len(self._next_t)

    def due(self, t: float, listeners: Sequence[str]) -> np.ndarray:
        """Indices into `listeners` of those whose scene is due at session time `t` [s]: the
        members of the most overdue group, if any is due."""
        self._learn_tick(t)
        self._deal(t, listeners)
        due = [g for g, next_t in enumerate(self._next_t) if t >= next_t]
        if not due:
            return np.zeros(0, dtype=np.intp)
        group = min(due, key=self._next_t.__getitem__)
        # Keep the cadence, but never schedule into the past: no burst after a stall.
        next_t = self._next_t[group] + self._period_s
        self._next_t[group] = max(next_t, t + self._period_s / 2)
        return np.flatnonzero(self._dealt_groups == group)

    def _learn_tick(self, t: float) -> None:
        if self._last_t is not None and t > self._last_t:
            self._gaps_s.append(t - self._last_t)
        self._last_t = t

    def _wanted_groups(self, listeners: int) -> int:
        ticks_per_period = math.floor(self._period_s / statistics.median(self._gaps_s) + 1e-6)
        return max(1, min(ticks_per_period, listeners // GROUP_MIN_LISTENERS))

    def _deal(self, t: float, listeners: Sequence[str]) -> None:
        wanted = self._wanted_groups(len(listeners))
        if wanted == self.groups and listeners == self._dealt:
            return  # the usual tick: the same listeners as the last one
        present = set(listeners)
        for gone in [n for n in self._group if n not in present]:
            del self._group[gone]
        if wanted != self.groups:
            self._regroup(t, wanted)
        sizes = self._sizes()
        for newcomer in [n for n in listeners if n not in self._group]:
            smallest = sizes.index(min(sizes))
            self._group[newcomer] = smallest
            sizes[smallest] += 1
        while max(sizes) - min(sizes) > 1:
            largest, smallest = sizes.index(max(sizes)), sizes.index(min(sizes))
            newest = next(n for n in reversed(self._group) if self._group[n] == largest)
            self._group[newest] = smallest
            sizes[largest] -= 1
            sizes[smallest] += 1
        self._dealt = list(listeners)
        self._dealt_groups = np.array([self._group[n] for n in listeners], dtype=np.intp)

    def _regroup(self, t: float, groups: int) -> None:
        """`groups` phases spread over the period after group 0's; the members of dropped
        groups go to group 0 (the balance in `_deal` evens the sizes out)."""
        anchor = self._next_t[0] if self._next_t[0] > -math.inf else t
        step = self._period_s / groups
        self._next_t = [anchor + g * step for g in range(groups)]
        for n, g in self._group.items():
            if g >= groups:
                self._group[n] = 0

    def _sizes(self) -> list[int]:
        sizes = [0] * self.groups
        for g in self._group.values():
            sizes[g] += 1
        return sizes
