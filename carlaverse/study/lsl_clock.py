"""LSL time <-> session time on this host (docs/architecture.md §5).

Session time is the authority's clock. Here it is followed on liblsl's `local_clock()`: a
`SessionClock` whose local clock *is* the LSL clock, kept in sync by querying
`authority/clock` as nodes do. Then

    session time = LSL local time + offset        (the offset applied now)

holds for every LSL timestamp already moved to this host's clock (an inlet's
`time_correction()` does that for a remote producer), with the offset's error bound half the
best clock query's round trip (`uncertainty_s`), as for every node.
"""

from __future__ import annotations

import logging
import threading

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.transport.clock import Clock, SessionClock

log = logging.getLogger(__name__)

SYNC_PERIOD_S = 1.0  # [s] between clock queries once synced (nodes: clock_sync_period_s)
BURST = 8  # queries at the start: the tightest of them sets the first offset
QUERY_TIMEOUT_S = 0.5  # [s] one query at most; its error bound is RTT / 2


class SessionTimeFollower:
    """Follows the session clock on `local` (an `LslClock`) from a background thread."""

    def __init__(self, session: zenoh.Session, keys: Keys, local: Clock, node_id: str = "") -> None:
        self._session = session
        self._key = keys.authority("clock")
        self._request = m.CLOCK_REQUEST.encode(m.ClockRequest(node_id))
        self.clock = SessionClock(local)
        self.unanswered = 0  # clock queries without a (decodable) reply
        self._stop = threading.Event()
        self._synced = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lsl-session-clock", daemon=True)

    def start(self) -> SessionTimeFollower:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2 * QUERY_TIMEOUT_S + 1)

    def wait_synced(self, timeout_s: float) -> bool:
        """Whether an authority answered a clock query within `timeout_s` [s]."""
        return self._synced.wait(timeout_s)

    @property
    def synced(self) -> bool:
        return self._synced.is_set()

    def to_session(self, local_t: float) -> float:
        """Session time [s] of LSL local time `local_t` [s] on this host."""
        return local_t + self.clock.offset

    def to_local(self, session_t: float) -> float:
        """LSL local time [s] on this host of session time `session_t` [s]."""
        return session_t - self.clock.offset

    @property
    def uncertainty_s(self) -> float:
        """The bound on the offset's error [s] (inf until synced)."""
        return self.clock.uncertainty_s

    def _run(self) -> None:
        queries = 0
        while not self._stop.is_set():
            self._sync_once()
            queries += 1
            self._stop.wait(0.02 if queries < BURST else SYNC_PERIOD_S)

    def _sync_once(self) -> None:
        local = self.clock.local
        t0 = local.now()
        raw = self._ask()
        t1 = local.now()
        if raw is None:
            self.unanswered += 1
            return
        try:
            reply = m.CLOCK_REPLY.decode(raw)
        except m.MessageError as exc:
            self.unanswered += 1
            log.warning("unreadable clock reply on %s: %s", self._key, exc)
            return
        self.clock.add_exchange(t0, reply.t, t1)
        self._synced.set()

    def _ask(self) -> bytes | None:
        try:
            for reply in self._session.get(
                self._key, payload=self._request, timeout=QUERY_TIMEOUT_S
            ):
                if reply.ok is not None:
                    return reply.ok.payload.to_bytes()
        except zenoh.ZError as exc:
            log.warning("clock query %s failed: %s", self._key, exc)
        return None
