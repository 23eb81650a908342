"""Joining, clocking and leaving for many synthetic egos on one Zenoh session.

Each ego goes through the same membership as a real node (`NodeClient`): the `authority/join`
query with a `JoinRequest` of the current schema, a liveliness token on `node/<id>` once
accepted, and at the end the `authority/leave` query before the token is dropped, so the
authority announces `left` rather than a loss. What a swarm shares is the session clock: one
process, one clock synchronised through the first ego's id.
"""

from __future__ import annotations

import logging
import socket
import threading
import uuid
from concurrent.futures import ThreadPoolExecutor

import zenoh

from carlaverse import __version__
from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.transport.clock import SessionClock
from carlaverse.transport.node_client import LEAVE_EVENT_WAIT_S
from carlaverse.zenoh_replies import ask

log = logging.getLogger(__name__)

JOIN_WORKERS = 8  # join queries in flight at once: a 256-ego swarm joins in about a second


class SwarmMembership:
    """The join state of every ego of a swarm; `joined[i]` says whether ego i may publish."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        node_ids: list[str],
        kind: str,
        actor_kind: str,
        pose_rate_hz: float,
    ) -> None:
        self.session = session
        self.keys = keys
        self.node_ids = node_ids
        self.kind = kind
        self.actor_kind = actor_kind
        self.pose_rate_hz = pose_rate_hz
        self.instances = [uuid.uuid4().hex for _ in node_ids]
        self.joined = [False] * len(node_ids)
        self.refused: dict[str, str] = {}  # node id -> the authority's reason
        self.joins = 0  # accepted join replies, re-joins included
        self.left = 0  # leave queries the authority confirmed
        self._tokens: list[zenoh.LivelinessToken | None] = [None] * len(node_ids)

    @property
    def joined_count(self) -> int:
        return sum(self.joined)

    def join_missing(self, timeout_s: float) -> int:
        """Ask the authority to admit every ego not yet admitted; return how many it took."""
        missing = [i for i, ok in enumerate(self.joined) if not ok and self.node_ids[i] not in
                   self.refused]  # fmt: skip
        with ThreadPoolExecutor(JOIN_WORKERS, thread_name_prefix="swarm-join") as pool:
            accepted = sum(pool.map(lambda i: self._join(i, timeout_s), missing))
        return accepted

    def forget(self) -> None:
        """The authority lost us (restart): every ego must join again."""
        self.joined = [False] * len(self.node_ids)

    def _join(self, i: int, timeout_s: float) -> bool:
        node_id = self.node_ids[i]
        request = m.JoinRequest(
            schema=m.SCHEMA_VERSION, node_id=node_id, instance=self.instances[i], kind=self.kind,
            actor_kind=self.actor_kind, site="swarm", hostname=socket.gethostname(),
            version=__version__, pose_rate_hz=self.pose_rate_hz,
        )  # fmt: skip
        raw = self._ask(self.keys.authority("join"), m.JOIN_REQUEST.encode(request), timeout_s)
        if raw is None:
            return False
        try:
            reply = m.JOIN_REPLY.decode(raw)
        except m.MessageError as exc:
            log.warning("unreadable join reply for %s: %s", node_id, exc)
            return False
        if not reply.accepted:
            self.refused[node_id] = reply.reason
            return False
        if self._tokens[i] is None:
            self._tokens[i] = self.session.liveliness().declare_token(self.keys.node(node_id))
        self.joined[i] = True
        self.joins += 1
        return True

    def sync_clock(self, clock: SessionClock, timeout_s: float = 0.5) -> bool | None:
        """One clock exchange in the first ego's name; whether the authority knows it
        (None without an answer)."""
        local = clock.local
        request = m.CLOCK_REQUEST.encode(m.ClockRequest(self.node_ids[0]))
        t0 = local.now()
        raw = self._ask(self.keys.authority("clock"), request, timeout_s)
        t1 = local.now()
        if raw is None:
            return None
        try:
            reply = m.CLOCK_REPLY.decode(raw)
        except m.MessageError:
            return None
        clock.add_exchange(t0, reply.t, t1)
        return reply.known

    def leave_all(self, timeout_s: float = 1.0) -> None:
        """Leave on purpose (despawn reason `left`), then drop the tokens.

        The tokens go only after the authority's `left` events went out (or LEAVE_EVENT_WAIT_S
        passed): peers that see a token vanish first would read it as a loss.
        """
        joined = [i for i, ok in enumerate(self.joined) if ok]
        announced = _LeftEvents({self.node_ids[i] for i in joined})
        events = self.session.declare_subscriber(self.keys.world("events"), announced.on_sample)
        try:
            with ThreadPoolExecutor(JOIN_WORKERS, thread_name_prefix="swarm-leave") as pool:
                self.left = sum(pool.map(lambda i: self._leave(i, timeout_s), joined))
            announced.wait(self.left, LEAVE_EVENT_WAIT_S)
        finally:
            events.undeclare()
        for i, token in enumerate(self._tokens):
            if token is not None:
                token.undeclare()
                self._tokens[i] = None
        self.joined = [False] * len(self.node_ids)

    def _leave(self, i: int, timeout_s: float) -> bool:
        request = m.LeaveRequest(self.node_ids[i], self.instances[i])
        raw = self._ask(self.keys.authority("leave"), m.LEAVE_REQUEST.encode(request), timeout_s)
        if raw is None:
            return False
        try:
            return m.LEAVE_REPLY.decode(raw).left
        except m.MessageError:
            return False

    def _ask(self, key: str, payload: bytes, timeout_s: float) -> bytes | None:
        """The first good reply's payload, else None (an error reply is logged)."""
        return ask(self.session, key, payload, timeout_s)[0]


class _LeftEvents:
    """Counts the authority's `left` despawns of a set of ids (a Zenoh callback, never blocks)."""

    def __init__(self, node_ids: set[str]) -> None:
        self._waiting = node_ids
        self._seen: set[str] = set()
        self._changed = threading.Condition()

    def on_sample(self, sample: zenoh.Sample) -> None:
        try:
            event = m.WORLD_EVENT.decode(sample.payload.to_bytes())
        except m.MessageError:
            return
        if isinstance(event, m.Despawned) and event.reason == "left":
            with self._changed:
                if event.node_id in self._waiting:
                    self._seen.add(event.node_id)
                    self._changed.notify_all()

    def wait(self, count: int, timeout_s: float) -> bool:
        with self._changed:
            return self._changed.wait_for(lambda: len(self._seen) >= count, timeout_s)
