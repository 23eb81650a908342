"""Clocks: a monotonic source, a manual one for tests, and the session clock
(docs/architecture.md §5).

The authority's clock is the session's. A node measures the offset between its own monotonic
clock and the session clock by querying `authority/clock`: for each exchange it knows when it
asked (t0) and heard back (t1) on its own clock and what the authority said (ts); assuming
symmetric paths, offset = ts − (t0 + t1) / 2, with an error bound of RTT / 2. The sample with
the smallest RTT in a sliding window has the tightest bound, so that is the estimate (NTP's
clock filter does the same); the slope of the estimates over time is the skew between the
two oscillators.

Session time must never step back: published `pose.t` inherits every step, and a receiver
interpolating between samples would see time run backwards. So, as NTP's discipline does, a
new estimate is not applied at once: the applied offset follows the skew and *slews* toward
the estimate at most `max_slew` seconds per second (1 %: a 20 ms correction takes 2 s, and
time never runs slower than 0.99× or faster than 1.01× real time). It steps only at the first
exchange, or forward when the error exceeds `step_threshold_s` (logged); a large backward
error is slewed too, never stepped, unless a new authority (`reset`) brings a new timeline.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from typing import NamedTuple, Protocol

log = logging.getLogger(__name__)

MAX_SLEW = 0.01  # [s/s] largest rate of offset correction
STEP_THRESHOLD_S = 0.25  # [s] a forward error beyond this is stepped, not slewed
SKEW_LIMIT = 500e-6  # [s/s] largest believable oscillator skew (quartz: < 100 ppm)
SKEW_MIN_SPAN_S = 30.0  # [s] estimates spread over less than this give no skew


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on a monotonic timeline."""
        ...


class MonotonicClock:
    # The C function itself, no Python frame around it: every pose a node hears is stamped
    # with it, on a thread that has just woken with cold caches, where each frame costs µs.
    now = staticmethod(time.monotonic)


class ManualClock:
    """A clock tests move by hand."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = start
        self._lock = threading.Lock()

    def now(self) -> float:
        return self._t

    def advance(self, dt: float) -> float:
        with self._lock:
            self._t += dt
            return self._t

    def set(self, t: float) -> None:
        with self._lock:
            self._t = t


class WallAlignedClock:
    """Monotonic time shifted to read as Unix time at construction: the authority's clock.

    It never jumps with NTP adjustments, yet a restarted authority on the same host continues
    the same timeline to within clock-sync precision, and recordings carry absolute times.
    """

    def __init__(self) -> None:
        self._offset = time.time() - time.monotonic()

    def now(self) -> float:
        return time.monotonic() + self._offset


class Exchange(NamedTuple):
    rtt: float  # [s]
    offset: float  # [s] session − local, assuming symmetric paths
    local_t: float  # [s] local time of the exchange's midpoint


class _Anchor(NamedTuple):
    """The applied offset at one local time, with what moves it from there (see `_offset_at`)."""

    applied: float  # [s] offset applied at local time `at`
    at: float  # [s] local time
    skew: float  # [s/s]
    target: float  # [s] the estimated offset at local time `target_at`
    target_at: float  # [s]
    max_slew: float  # [s/s]


def _offset_at(a: _Anchor, t: float) -> float:
    """The offset applied at local time `t` [s]: it follows the skew and slews toward the
    estimate at most `max_slew` s/s (for t before the anchor: the anchor's offset)."""
    applied, at, skew, target, target_at, max_slew = a  # unpacked: cheaper than attributes
    dt = t - at
    if dt <= 0:
        return applied
    predicted = applied + skew * dt
    error = target + skew * (t - target_at) - predicted
    bound = max_slew * dt
    return predicted + (bound if error > bound else -bound if error < -bound else error)


class SessionClock:
    """Session time for a node: its local clock plus a disciplined offset to the authority.

    Reading it takes no lock (Zenoh's callbacks stamp arrivals with it): writers, under the
    lock, publish an immutable `_Anchor` that readers evaluate at their own local time.
    """

    def __init__(
        self,
        local: Clock,
        window: int = 16,
        max_slew: float = MAX_SLEW,
        step_threshold_s: float = STEP_THRESHOLD_S,
    ) -> None:
        self.local = local
        self.max_slew = max_slew
        self.step_threshold_s = step_threshold_s
        # Until the first exchange, assume the hosts' wall clocks agree (NTP-synced lab hosts):
        # far better than zero, and replaced by a measurement within a second of joining.
        guess = time.time() - time.monotonic() if isinstance(local, MonotonicClock) else 0.0
        self._samples: deque[Exchange] = deque(maxlen=window)
        self._history: deque[Exchange] = deque(maxlen=256)  # ~3 min of syncs, for the skew
        self._estimate = Exchange(0.0, guess, local.now())
        self.skew = 0.0  # [s/s] session clock rate − local clock rate
        self._applied = guess
        self._applied_at = self._estimate.local_t
        self._lock = threading.Lock()
        self.synced = False
        self._new_timeline = True  # the next exchange may step (first sync, or after reset)
        self.steps = 0
        self._anchor = self._make_anchor()

    def now(self) -> float:
        t = self.local.now()
        return t + _offset_at(self._anchor, t)

    def at(self, local_t: float) -> float:
        """Session time at local time `local_t` [s] (a stamp taken with `local.now()`)."""
        return local_t + _offset_at(self._anchor, local_t)

    @property
    def offset(self) -> float:
        """The offset applied now [s]: session time − local time."""
        return _offset_at(self._anchor, self.local.now())

    def _make_anchor(self) -> _Anchor:
        est = self._estimate
        return _Anchor(
            self._applied, self._applied_at, self.skew, est.offset, est.local_t, self.max_slew
        )

    @property
    def uncertainty_s(self) -> float:
        """Half the best RTT in the window: the bound on the offset error."""
        return min(s.rtt for s in self._samples) / 2 if self._samples else float("inf")

    def target(self, local_t: float) -> float:
        """The estimated offset at local time `local_t` [s]."""
        return self._estimate.offset + self.skew * (local_t - self._estimate.local_t)

    def add_exchange(self, t0: float, ts: float, t1: float) -> None:
        """Record one clock query: sent at local t0, answered with session ts, heard at t1."""
        rtt = t1 - t0
        if rtt < 0:
            return
        sample = Exchange(rtt, ts - (t0 + t1) / 2, (t0 + t1) / 2)
        with self._lock:
            self._advance(self.local.now())  # up to now at the old estimate and skew
            if self._samples and not self._consistent(sample):
                self._samples.clear()  # the timeline moved: older samples would hold it back
                self._history.clear()
            self._samples.append(sample)
            self._history.append(sample)
            self._estimate = min(self._samples)
            self.skew = _skew(self._history, self.skew)
            self._discipline(self.local.now())
            self.synced = True
            self._anchor = self._make_anchor()

    def reset(self) -> None:
        """Forget the window: a new authority may bring a new timeline (a step is allowed)."""
        with self._lock:
            self._samples.clear()
            self._history.clear()
            self._new_timeline = True

    def _consistent(self, sample: Exchange) -> bool:
        """Can `sample` and the estimate both be right? Each exchange bounds the true offset
        to its offset ± RTT/2 (whatever the path asymmetry); if the two intervals, carried to
        the same time with any believable skew, do not overlap, the authority's timeline moved
        (or the path changed) and the older samples are no longer evidence."""
        est = self._estimate
        drift = SKEW_LIMIT * abs(sample.local_t - est.local_t)
        bound = (sample.rtt + est.rtt) / 2 + drift
        return abs(sample.offset - self.target(sample.local_t)) <= bound

    def _advance(self, t: float) -> None:
        """Move the applied offset to local time `t`: follow the skew, slew toward the target."""
        if t > self._applied_at:
            self._applied = _offset_at(self._make_anchor(), t)
            self._applied_at = t

    def _discipline(self, t: float) -> None:
        self._advance(t)
        error = self.target(t) - self._applied
        first = not self.synced
        if first or (self._new_timeline and abs(error) > self.step_threshold_s):
            self._step(t, error, "first sync" if first else "new authority timeline")
        elif error > self.step_threshold_s:
            self._step(t, error, "error beyond the step threshold")
        elif error < -self.step_threshold_s:
            log.warning("session clock %.3f s ahead; slewing back, never stepping", -error)
        self._new_timeline = False

    def _step(self, t: float, error: float, why: str) -> None:
        self._applied += error
        self._applied_at = t
        self.steps += 1
        level = logging.INFO if why == "first sync" else logging.WARNING
        log.log(level, "session clock stepped by %+.6f s (%s)", error, why)


def _skew(history: deque[Exchange], previous: float) -> float:
    """Least-squares slope of the tight offset estimates over time, clamped to SKEW_LIMIT;
    `previous` while the history is too short to tell.

    Only exchanges whose RTT is near the best take part: a slow exchange's offset is off by up
    to half its RTT, which over a short span would read as a large skew.
    """
    if len(history) < 4:
        return previous
    best = min(s.rtt for s in history)
    tight = [s for s in history if s.rtt <= 2 * best + 0.0005]
    span = tight[-1].local_t - tight[0].local_t if len(tight) > 1 else 0.0
    if len(tight) < 4 or span < SKEW_MIN_SPAN_S:
        return previous
    mt = sum(s.local_t for s in tight) / len(tight)
    mo = sum(s.offset for s in tight) / len(tight)
    num = sum((s.local_t - mt) * (s.offset - mo) for s in tight)
    den = sum((s.local_t - mt) ** 2 for s in tight)
    return max(-SKEW_LIMIT, min(SKEW_LIMIT, num / den))
