"""A replay's stand-in for the session's authority: it answers what the authority answers.

A node, viewer, renderer or recorder joins a session by asking its authority: `join` (is it
admitted?), `clock` (what is session time?), `snapshot` (who is here, and where?), `map`,
`scenario` and `configs`; it accepts world messages only stamped by the session it joined
(`transport.inbound`). So that every one of them works on a replay exactly as on a live
session, the replaying process is that authority for its target session:

- `join` admits observers, and only them: a replay has no live actors besides the recorded
  ones, and a driving node would move among actors that cannot see it. A refused join names
  why. Its reply names this session's zid, and the replay stamps the world messages it
  republishes (`world/*`, `impulse/*`, `audio/*`) with this session's timestamps.
- `clock` answers recorded session time as the replay plays it (`replay_clock`), so the
  replayed poses are at session time on arrival.
- `snapshot` lists the world as replayed so far (`replay_world`); `map`, `scenario` and
  `configs` answer the recorded replies (configs redacted again), the first ones before the
  replay reaches them, then the newest replayed.
- `leave` lets an observer go (its `left` event goes out as a live authority's would).

It declares the authority's liveliness token, so clients see an authority (and wait for none).
A new pass of a looping replay is a new authority timeline: every recorded actor is despawned
and the token declared again, which makes nodes join again and let their clocks step back.

Queries are answered in Zenoh's callbacks, which never publish nor raise: events wait in a
queue for the outbox thread; a request that does not decode gets an error reply and is counted.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections import Counter
from collections.abc import Callable

import zenoh

from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, AUTHORITY_QUERIES, Keys, KeySpaceError, check_token
from carlaverse.recording.replay_clock import ReplayClock
from carlaverse.recording.replay_world import ReplayedWorld
from carlaverse.recording.scrub import scrub_configs

log = logging.getLogger(__name__)

SERVED = ("map", "scenario", "configs")  # answered with the recorded reply
MAX_OBSERVERS = 512  # admitted at once; the oldest is forgotten past it
DESPAWN_TIMEOUT_S = 3.0  # [s] what the join reply tells (a live authority's default)
NO_REPLY = {
    "map": "the recording holds no map (its session ran no scenario)",
    "scenario": "the recording holds no scenario",
    "configs": "the recording holds no configs",
}


class ReplayAuthority:
    """Answers a replay session's authority queries; `start()` declares them and the token."""

    def __init__(self, session: zenoh.Session, keys: Keys, clock: ReplayClock) -> None:
        self.session = session
        self.keys = keys
        self.clock = clock
        self.world = ReplayedWorld()
        self.instance = str(session.zid())  # nodes accept world messages stamped with it
        self.observers: dict[str, str] = {}  # admitted node id -> its instance
        self.counts: Counter[str] = Counter()  # joins, refusals, bad requests, handler errors
        self._replies: dict[str, bytes] = {}  # recorded map | scenario | configs
        self._events: queue.SimpleQueue[m.WorldEvent | None] = queue.SimpleQueue()
        self._seq = 0
        self._lock = threading.Lock()  # the observers and the event sequence
        self._entities: list[zenoh.Queryable] = []
        self._token: zenoh.LivelinessToken | None = None
        self._events_pub: zenoh.Publisher | None = None
        self._outbox = threading.Thread(target=self._send_events, name="replay-outbox", daemon=True)

    # ------------------------------------------------------------ lifecycle

    @property
    def started(self) -> bool:
        return self._token is not None

    def start(self) -> ReplayAuthority:
        handlers: dict[str, Callable[[zenoh.Query], None]] = {
            "join": self._on_join, "leave": self._on_leave, "clock": self._on_clock,
            "snapshot": self._on_snapshot,
        }  # fmt: skip
        handlers.update({name: self._served(name) for name in SERVED})
        assert set(handlers) == set(AUTHORITY_QUERIES)  # every query a node may ask
        for name, handler in handlers.items():
            queryable = self.session.declare_queryable(
                self.keys.authority(name), self._guarded(name, handler), complete=True
            )
            self._entities.append(queryable)
        self._events_pub = self.session.declare_publisher(
            self.keys.world("events"), congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )  # fmt: skip
        self._outbox.start()
        self._token = self.session.liveliness().declare_token(self.keys.node(AUTHORITY_ID))
        return self

    def close(self) -> None:
        """The reverse of start(): the token goes last, as a live authority's does."""
        for entity in self._entities:
            entity.undeclare()
        self._entities.clear()
        self._events.put(None)
        if self._outbox.is_alive():
            self._outbox.join(timeout=5)
        if self._events_pub is not None:
            self._events_pub.undeclare()
            self._events_pub = None
        if self._token is not None:
            self._token.undeclare()
            self._token = None

    def stamp(self) -> zenoh.Timestamp:
        """A timestamp of this session: what makes a world message the authority's."""
        return self.session.new_timestamp()

    # ------------------------------------------------------------ what the replay feeds

    def recorded_reply(self, query: str, payload: bytes) -> None:
        """A recorded `authority/<query>` reply, served from now on (configs redacted)."""
        if query in SERVED:
            self._replies[query] = scrub_configs(payload) if query == "configs" else payload

    def new_timeline(self) -> None:
        """A new pass: every recorded actor leaves, and the authority appears anew. Called by
        the replay thread between passes (it publishes: never from a callback)."""
        t = self.clock.now()
        for node_id in self.world.actors():
            self._publish(m.Despawned(self._next_seq(), t, node_id, "authority"))
        self.world.clear()
        if self._token is not None:  # nodes join again, and their clocks may step back
            self._token.undeclare()
            self._token = self.session.liveliness().declare_token(self.keys.node(AUTHORITY_ID))

    # ------------------------------------------------------------ queries

    def _guarded(
        self, name: str, handler: Callable[[zenoh.Query], None]
    ) -> Callable[[zenoh.Query], None]:
        def answer(query: zenoh.Query) -> None:
            try:
                handler(query)
            except Exception:  # nothing may raise into Zenoh: counted, logged, answered
                self.counts[f"{name}/error"] += 1
                log.exception("the replay's %s query failed", name)
                _reply_err(query, f"the replay could not answer {name}")

        return answer

    def _request(self, query: zenoh.Query, what: str) -> object | None:
        """The query's request decoded, or None after an error reply naming the problem."""
        try:
            payload = query.payload
            return m.REQUEST_CODECS[what].decode(payload.to_bytes() if payload else b"")
        except m.MessageError as exc:
            self.counts[f"{what}/bad_request"] += 1
            _reply_err(query, f"bad {what} request: {exc}")
            return None

    def _on_join(self, query: zenoh.Query) -> None:
        req = self._request(query, "join")
        if not isinstance(req, m.JoinRequest):
            return
        problem = self._join_problem(req)
        if problem:
            self.counts["join/refused"] += 1
            log.warning("refused join of %r: %s", req.node_id, problem)
        else:
            self._admit(req)
        reply = m.JoinReply(
            schema=m.SCHEMA_VERSION, accepted=not problem, reason=problem,
            session=self.keys.session, despawn_timeout_s=DESPAWN_TIMEOUT_S,
            authority_instance=self.instance, pose_digest_s=0.0,  # each pose on its own key
        )  # fmt: skip
        query.reply(query.key_expr, m.JOIN_REPLY.encode(reply))

    def _join_problem(self, req: m.JoinRequest) -> str:
        """Why `req` cannot join a replay, or "" if it can (one line naming the fix)."""
        if req.schema != m.SCHEMA_VERSION:
            return (f"schema version {req.schema} does not match the replay's "
                    f"{m.SCHEMA_VERSION}; run the same carlaverse version")  # fmt: skip
        if req.node_id == AUTHORITY_ID:
            return f"node id {AUTHORITY_ID!r} is reserved for the authority; choose another --id"
        try:
            check_token(req.node_id)
            check_token(req.instance, "instance")
        except KeySpaceError as exc:
            return str(exc)
        if req.actor_kind:
            return (
                f"session {self.keys.session!r} replays a recording: only observers join it, "
                f"a {req.kind} node's {req.actor_kind} would move among recorded actors that "
                "cannot see it (join a live session to drive)"
            )
        if self.world.is_present(req.node_id):
            return f"node id {req.node_id!r} is a recorded node's; choose another --id"
        return ""

    def _admit(self, req: m.JoinRequest) -> None:
        with self._lock:
            new = self.observers.get(req.node_id) != req.instance
            self.observers.pop(req.node_id, None)
            self.observers[req.node_id] = req.instance  # newest last
            while len(self.observers) > MAX_OBSERVERS:
                del self.observers[next(iter(self.observers))]
        self.counts["join/accepted"] += 1
        if new:
            t = self.clock.now()
            self._queue_event(lambda seq: m.Spawned(seq, t, req.node_id, req.kind, ""))

    def _on_leave(self, query: zenoh.Query) -> None:
        req = self._request(query, "leave")
        if not isinstance(req, m.LeaveRequest):
            return
        with self._lock:
            left = self.observers.get(req.node_id) == req.instance
            if left:
                del self.observers[req.node_id]
        if left:
            t = self.clock.now()
            self._queue_event(lambda seq: m.Despawned(seq, t, req.node_id, "left"))
        query.reply(query.key_expr, m.LEAVE_REPLY.encode(m.LeaveReply(left)))

    def _on_clock(self, query: zenoh.Query) -> None:
        t = self.clock.now()  # first, so the reply's time is as close to the answer as can be
        req = self._request(query, "clock")
        if not isinstance(req, m.ClockRequest):
            return
        known = req.node_id in self.observers
        query.reply(query.key_expr, m.CLOCK_REPLY.encode(m.ClockReply(t, known)))

    def _on_snapshot(self, query: zenoh.Query) -> None:
        snapshot = self.world.snapshot(self.clock.now())
        query.reply(query.key_expr, m.SNAPSHOT.encode(snapshot))

    def _served(self, name: str) -> Callable[[zenoh.Query], None]:
        def answer(query: zenoh.Query) -> None:
            payload = self._replies.get(name)
            if payload:  # a configs reply that could not be checked is withheld (b"")
                query.reply(query.key_expr, payload)
            else:
                _reply_err(query, NO_REPLY[name])

        return answer

    # ------------------------------------------------------------ the outbox thread

    def _next_seq(self) -> int:
        with self._lock:
            self._seq += 1
            return self._seq

    def _queue_event(self, make: Callable[[int], m.WorldEvent]) -> None:
        self._events.put(make(self._next_seq()))

    def _send_events(self) -> None:
        """Publish queued events (a reliable put may wait: never in a callback)."""
        while True:
            event = self._events.get()
            if event is None:
                return
            self._publish(event)

    def _publish(self, event: m.WorldEvent) -> None:
        if self._events_pub is not None:
            self._events_pub.put(m.WORLD_EVENT.encode(event), timestamp=self.stamp())


def _reply_err(query: zenoh.Query, reason: str) -> None:
    """Answer a query with an error; a query already answered or gone is no error of ours."""
    try:
        query.reply_err(reason.encode())
    except Exception as exc:  # the asker left or was answered already: nothing to tell it
        log.debug("could not answer a query: %s", exc)
