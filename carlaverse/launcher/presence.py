"""Who is in a session, from which site, and how well their poses arrive.

The launcher watches a session as an observer, exactly as `carlaverse stats` does (the same
`NodeClient`, the same per-node `summaries`), in a thread of its own; the page reads `rows()`.
Kind and site come from the authority's snapshot, asked again every few seconds so nodes that
join later, from any site, show with theirs.
"""

from __future__ import annotations

import logging
import math
import threading
import time

import msgspec

from carlaverse import messages as m
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import (
    FabricError,
    FabricSettings,
    open_session,
    reachable,
    reaches_anyone,
)
from carlaverse.world.stream_summary import StreamSummary, summaries

log = logging.getLogger(__name__)

UPDATE_PERIOD_S = 0.5  # [s] how often the table is recomputed
ROSTER_PERIOD_S = 3.0  # [s] how often kinds and sites are asked of the authority


class PresenceRow(msgspec.Struct, frozen=True):
    """One node as the launcher lists it; NaN where nothing was measured yet."""

    node_id: str
    kind: str = ""
    site: str = ""
    rate_hz: float = math.nan
    latency_p50_ms: float = math.nan
    latency_p99_ms: float = math.nan
    loss: float = math.nan
    last_seen_s: float = math.nan


class SessionWatch:
    """An observer of one session on `endpoint`, run in a daemon thread until `close()`."""

    def __init__(self, endpoint: str, session: str, observer_id: str = "launcher") -> None:
        self.endpoint = endpoint
        self.session_name = session
        self.settings = NodeSettings(
            node_id=observer_id, session=session, kind="observer", actor_kind=""
        )
        self.error = ""
        self._client: NodeClient | None = None  # set once the session is open
        self._rows: list[PresenceRow] = []
        self._roster: dict[str, m.EgoInfo] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="launcher-watch", daemon=True)

    def start(self) -> SessionWatch:
        self._thread.start()
        return self

    def rows(self) -> list[PresenceRow]:
        with self._lock:
            return list(self._rows)

    def authority_line(self) -> str:
        """One line: whether the session's authority is there, as this watch sees it now
        (joined to it means it runs; a watch that lost it is waiting to join again)."""
        client, session = self._client, self.session_name
        if self.error:
            return self.error
        if self._stop.is_set():
            return f"session {session!r} is no longer watched"
        if client is None:
            return f"connecting to the router at {self.endpoint}"
        if not reaches_anyone(client.session):
            return f"the router at {self.endpoint} does not answer (retrying)"
        if client.refused is not None:
            return f"the authority of session {session!r} refused this watch: {client.refused}"
        if client.joined.is_set():
            return f"the authority of session {session!r} is running"
        return f"no authority of session {session!r} is running (start one, or a demo)"

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)

    def _run(self) -> None:
        try:
            session = open_session(reachable(FabricSettings(connect=[self.endpoint])))
        except FabricError as exc:
            self.error = str(exc)
            return
        client = self._client = NodeClient(session, self.settings, MonotonicClock()).start()
        try:
            self._observe(client)
        finally:
            self._client = None  # the page may still ask authority_line(): not of a closed session
            client.close()
            session.close()

    def _observe(self, client: NodeClient) -> None:
        next_roster = time.monotonic()
        while not self._stop.is_set():
            now = client.update()
            if time.monotonic() >= next_roster and client.joined.is_set():
                self._ask_roster(client)
                next_roster = time.monotonic() + ROSTER_PERIOD_S
            rows = presence_rows(
                client.world.present, summaries(client.world.stats, now), self._roster
            )
            with self._lock:
                self._rows = rows
            self._stop.wait(UPDATE_PERIOD_S)

    def _ask_roster(self, client: NodeClient) -> None:
        raw = client.query("snapshot", timeout_s=1.0)
        if raw is None:
            return
        try:
            snapshot = m.SNAPSHOT.decode(raw)
        except m.MessageError as exc:  # counted by nobody else: say it, keep the old roster
            log.warning("unreadable snapshot from the authority: %s", exc)
            return
        self._roster = {ego.node_id: ego for ego in snapshot.egos}


def presence_rows(
    present: set[str], stats: dict[str, StreamSummary], roster: dict[str, m.EgoInfo]
) -> list[PresenceRow]:
    """One row per node present now (its liveliness token seen, not yet gone), sorted by
    site then id; a node that left keeps its statistics in `stats` but is not listed."""
    rows = []
    for node_id in sorted(present):
        info = roster.get(node_id)
        summary = stats.get(node_id)
        measured = msgspec.structs.asdict(summary) if summary is not None else {}
        measured.pop("samples", None)
        measured.pop("jitter_ms", None)
        rows.append(
            PresenceRow(
                node_id,
                kind=info.kind if info else "",
                site=info.site if info else "",
                **measured,
            )
        )
    return sorted(rows, key=lambda r: (r.site, r.node_id))
