"""The authority process: presence, joins, the session clock, despawns and the world tick.

Queries are answered in Zenoh's callbacks (they only read or update the roster under a short
lock); poses are queued and applied by the tick thread, which also runs the global domain
and publishes what it decided. The tick runs at a fixed rate and measures itself.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections import deque

import msgspec
import zenoh

from carlaverse import messages as m
from carlaverse.authority.domain import EgoTrack, GlobalDomain
from carlaverse.authority.membership import Roster
from carlaverse.authority.outbox import ZenohOutbox
from carlaverse.config import StrictStruct
from carlaverse.fabric.clock import Clock
from carlaverse.fabric.stats import percentile
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, parse

log = logging.getLogger(__name__)


class AuthoritySettings(StrictStruct):
    session: str = "default"
    tick_hz: float = 50.0
    despawn_timeout_s: float = 3.0


class TickSummary(msgspec.Struct, frozen=True):
    ticks: int
    tick_p50_ms: float
    tick_p99_ms: float
    overruns: int


class Authority:
    def __init__(
        self,
        session: zenoh.Session,
        settings: AuthoritySettings,
        clock: Clock,
        domain: GlobalDomain,
    ) -> None:
        self.session = session
        self.settings = settings
        self.clock = clock
        self.domain = domain
        self.keys = Keys(settings.session)
        self.instance = uuid.uuid4().hex
        self.roster = Roster(settings.despawn_timeout_s)
        self.outbox = ZenohOutbox(session, self.keys)
        self.dropped: dict[str, int] = {}
        self.despawned: list[tuple[str, str]] = []  # (node id, reason)
        self.tick_ms: deque[float] = deque(maxlen=10_000)
        self.ticks = 0
        self.overruns = 0
        self._lock = threading.Lock()
        self._poses: deque[tuple[str, m.Pose, float]] = deque(maxlen=100_000)
        self._gone: deque[str] = deque()
        self._spawned: deque[m.Spawned] = deque()  # published by the tick, not the callback
        self._stop = threading.Event()
        self._entities: list[object] = []
        self._token: zenoh.LivelinessToken | None = None

    # ------------------------------------------------------------ lifecycle

    def start(self) -> Authority:
        k, s = self.keys, self.session
        queries = {
            "join": self._on_join,
            "clock": self._on_clock,
            "snapshot": self._on_snapshot,
            "configs": self._on_configs,
            "map": self._on_map,
            "scenario": self._on_scenario,
        }
        for name, handler in queries.items():
            self._entities.append(s.declare_queryable(k.authority(name), handler))
        self._entities.append(s.declare_subscriber(k.all_ego("pose"), self._on_pose))
        self._entities.append(s.declare_subscriber(k.all_ego("state"), self._on_state))
        self._entities.append(
            s.liveliness().declare_subscriber(k.all_nodes, self._on_presence, history=True)
        )
        # Declared last: nodes re-join when they see it, so the queryables must be up first.
        self._token = s.liveliness().declare_token(k.node(AUTHORITY_ID))
        return self

    def run(self, duration_s: float | None = None) -> None:
        """Tick at the configured rate until stop() or the duration has passed."""
        period = 1.0 / self.settings.tick_hz
        start = time.monotonic()
        next_t = start
        while not self._stop.is_set():
            if duration_s is not None and time.monotonic() - start >= duration_s:
                break
            began = time.perf_counter()
            self.tick(self.clock.now())
            self.tick_ms.append((time.perf_counter() - began) * 1e3)
            next_t += period
            delay = next_t - time.monotonic()
            if delay < 0:
                self.overruns += 1
                if delay < -period:
                    next_t = time.monotonic()  # do not burst to catch up
            self._stop.wait(max(0.0, delay))

    def stop(self) -> None:
        self._stop.set()

    def close(self) -> None:
        self._stop.set()
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        for entity in self._entities:
            entity.undeclare()  # type: ignore[attr-defined]
        self._entities.clear()
        self.domain.close()

    def summary(self) -> TickSummary:
        ticks = list(self.tick_ms)
        return TickSummary(
            ticks=self.ticks,
            tick_p50_ms=round(percentile(ticks, 0.5), 3),
            tick_p99_ms=round(percentile(ticks, 0.99), 3),
            overruns=self.overruns,
        )

    # ------------------------------------------------------------ tick

    def tick(self, t: float) -> None:
        """One step of the world at session time t."""
        self.ticks += 1
        with self._lock:
            while self._poses:
                self.roster.pose(*self._poses.popleft())
            gone = [(n, "liveliness") for n in self._drain_gone()]
            gone += [(n, "timeout") for n in self.roster.expired(t)]
            for node_id, reason in gone:
                self._despawn(node_id, reason, t)
            tracks = dict(self.roster.tracks)
        while self._spawned:
            event = self._spawned.popleft()
            self.outbox.event(msgspec.structs.replace(event, seq=self.outbox.next_seq()))
        self.domain.tick(t, tracks, self.outbox)

    def _drain_gone(self) -> list[str]:
        out = []
        while self._gone:
            out.append(self._gone.popleft())
        return out

    def _despawn(self, node_id: str, reason: str, t: float) -> None:
        if self.roster.remove(node_id) is None:
            return
        self.despawned.append((node_id, reason))
        log.info("despawn %s (%s)", node_id, reason)
        self.domain.ego_left(node_id)
        self.outbox.event(m.Despawned(self.outbox.next_seq(), t, node_id, reason))

    # ------------------------------------------------------------ subscriptions

    def _count_drop(self, what: str) -> None:
        self.dropped[what] = self.dropped.get(what, 0) + 1

    def _on_pose(self, sample: zenoh.Sample) -> None:
        rx_t = self.clock.now()
        try:
            node_id = parse(str(sample.key_expr)).node_id
            pose = m.POSE.decode(sample.payload.to_bytes())
        except (KeySpaceError, m.MessageError):
            self._count_drop("pose")
            return
        self._poses.append((node_id, pose, rx_t))

    def _on_state(self, sample: zenoh.Sample) -> None:
        try:
            node_id = parse(str(sample.key_expr)).node_id
            state = m.EGO_STATE.decode(sample.payload.to_bytes())
        except (KeySpaceError, m.MessageError):
            self._count_drop("state")
            return
        with self._lock:
            track = self.roster.tracks.get(node_id)
            if track is not None:
                track.info = msgspec.structs.replace(track.info, state=state)

    def _on_presence(self, sample: zenoh.Sample) -> None:
        try:
            node_id = parse(str(sample.key_expr)).node_id
        except KeySpaceError:
            self._count_drop("presence")
            return
        if node_id == AUTHORITY_ID:
            return
        with self._lock:
            if self.roster.token(node_id, sample.kind == zenoh.SampleKind.PUT):
                self._gone.append(node_id)

    # ------------------------------------------------------------ queries

    def _request(self, query: zenoh.Query, codec: m.Codec, what: str) -> object | None:
        try:
            payload = query.payload
            return codec.decode(payload.to_bytes() if payload is not None else b"")
        except m.MessageError as exc:
            self._count_drop(what)
            query.reply_err(f"bad {what} request: {exc}".encode())
            return None

    def _on_join(self, query: zenoh.Query) -> None:
        req = self._request(query, m.JOIN_REQUEST, "join")
        if req is None:
            return
        assert isinstance(req, m.JoinRequest)
        t = self.clock.now()
        with self._lock:
            decision = self.roster.join(req, t)
            if decision.accepted and decision.new and decision.track is not None:
                self.domain.ego_joined(decision.track)
                self.outbox.event(m.Spawned(self.outbox.next_seq(), t, req.node_id, req.kind))
        spawn = self.domain.spawn_point(req.kind, req.node_id) if decision.accepted else None
        reply = m.JoinReply(
            schema=m.SCHEMA_VERSION,
            accepted=decision.accepted,
            reason=decision.reason,
            session=self.settings.session,
            spawn=spawn,
            despawn_timeout_s=self.settings.despawn_timeout_s,
            tick_hz=self.settings.tick_hz,
            authority_instance=self.instance,
        )
        if not decision.accepted:
            log.warning("refused join of %r: %s", req.node_id, decision.reason)
        query.reply(query.key_expr, m.JOIN_REPLY.encode(reply))

    def _on_clock(self, query: zenoh.Query) -> None:
        t = self.clock.now()  # first, so the reply's time is as close to the answer as can be
        req = self._request(query, m.CLOCK_REQUEST, "clock")
        if req is None:
            return
        known = getattr(req, "node_id", "") in self.roster.tracks
        query.reply(query.key_expr, m.CLOCK_REPLY.encode(m.ClockReply(t, known)))

    def snapshot(self) -> m.Snapshot:
        with self._lock:
            egos = [_ego_info(track) for track in self.roster.tracks.values()]
        npc, lights, weather = self.domain.snapshot_parts()
        return m.Snapshot(m.SCHEMA_VERSION, self.clock.now(), egos, npc, lights, weather)

    def _on_snapshot(self, query: zenoh.Query) -> None:
        query.reply(query.key_expr, m.SNAPSHOT.encode(self.snapshot()))

    def _on_configs(self, query: zenoh.Query) -> None:
        with self._lock:
            nodes = {n: t.config_yaml for n, t in self.roster.tracks.items()}
            hosts = {n: str(t.extra.get("hostname", "")) for n, t in self.roster.tracks.items()}
        scenario = self.domain.scenario_reply()
        yaml = scenario.yaml if scenario else ""
        reply = m.ConfigsReply(m.SCHEMA_VERSION, nodes, yaml, hostnames=hosts)
        query.reply(query.key_expr, m.CONFIGS.encode(reply))

    def _on_map(self, query: zenoh.Query) -> None:
        reply = self.domain.map_reply()
        if reply is None:
            query.reply_err(b"this session has no map (the authority runs no scenario)")
        else:
            query.reply(query.key_expr, m.MAP.encode(reply))

    def _on_scenario(self, query: zenoh.Query) -> None:
        reply = self.domain.scenario_reply()
        if reply is None:
            query.reply_err(b"the authority runs no scenario")
        else:
            query.reply(query.key_expr, m.SCENARIO.encode(reply))


def _ego_info(track: EgoTrack) -> m.EgoInfo:
    return msgspec.structs.replace(track.info, pose=track.last_pose)
