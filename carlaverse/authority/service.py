"""The authority process: presence, joins, the session clock, despawns and the world tick.

Queries are answered in Zenoh's callbacks (they only read or update the roster under a short
lock, and never publish); poses wait in Zenoh's ring, without a Python callback, and are
decoded in batches and applied by the tick thread (`pose_intake`), which also
announces spawns and despawns, runs the global domain and publishes what it decided. The tick
runs at a fixed rate and measures itself. No callback raises into Zenoh: a bad payload is
counted in `drops` under its key, a well-formed but refused one in `rejected`, anything
unexpected in `guard.errors`; every query gets a reply, an error reply naming the reason if
the request cannot be read.

Despawn reasons: `left` (the node said so on `authority/leave`), `liveliness` (its token was
lost), `timeout` (silent for the despawn timeout), `authority` (a new process took over the id).
"""

from __future__ import annotations

import gc
import logging
import threading
import time
from collections import deque
from typing import Annotated

import msgspec
import zenoh

from carlaverse import messages as m
from carlaverse.authority.domain import EgoTrack, GlobalDomain
from carlaverse.authority.membership import Roster
from carlaverse.authority.outbox import ZenohOutbox
from carlaverse.authority.pose_digest import DIGEST_PERIOD_S, PoseDigestRelay
from carlaverse.authority.pose_intake import RING_CAPACITY, PoseIntake
from carlaverse.config import StrictStruct
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, parse
from carlaverse.realtime import raise_priority
from carlaverse.support.stats import percentile
from carlaverse.support.tally import Tally
from carlaverse.transport.clock import Clock
from carlaverse.transport.guard import HandlerGuard, reply_err

log = logging.getLogger(__name__)


DESPAWN_LOG = 10_000  # (node id, reason) pairs kept for the summary


class AuthoritySettings(StrictStruct):
    session: str = "default"
    tick_hz: float = 50.0
    despawn_timeout_s: float = 3.0
    # SCHED_FIFO priority of the tick thread where allowed (else nice -10), 0 = unchanged. On
    # a shared machine a tick preempted by the nodes' processes overruns however little it
    # has to do; real-time, the tick thread runs the moment its period comes.
    tick_priority: Annotated[int, msgspec.Meta(ge=0, le=99)] = 0
    # [s] how often the pose digest (`world/@egos`) relays the poses gathered since the last
    # one, while anything subscribes to it; 0: no digest.
    digest_period_s: Annotated[float, msgspec.Meta(ge=0, le=1)] = DIGEST_PERIOD_S


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
        # The session's zid: nodes accept world messages stamped with it (see the outbox).
        self.instance = str(session.zid())
        self.roster = Roster(settings.despawn_timeout_s)
        self.outbox = ZenohOutbox(session, self.keys)
        self.drops = Tally()  # undecodable payloads, by key
        self.rejected = Tally()  # well-formed but refused, by `<key>/<why>`
        self.guard = HandlerGuard(log)
        self.despawned: list[tuple[str, str]] = []  # (node id, reason), the last DESPAWN_LOG
        self.tick_ms: deque[float] = deque(maxlen=10_000)
        self.ticks = 0
        self.overruns = 0
        self.scheduling = "unchanged"  # how the tick thread is scheduled (`raise_priority`)
        self._lock = threading.Lock()
        self._intake: PoseIntake | None = None  # declared by start()
        self.digest: PoseDigestRelay | None = None  # started by start()
        self._gone: deque[tuple[str, str]] = deque()  # (node id, reason) for the tick
        # Spawns and despawns decided in callbacks, announced by the tick: a callback never
        # publishes (a reliable put may block under congestion).
        self._spawned: deque[m.WorldEvent] = deque()
        self._stop = threading.Event()
        self._entities: list[object] = []
        self._token: zenoh.LivelinessToken | None = None

    # ------------------------------------------------------------ lifecycle

    def start(self) -> Authority:
        k, s = self.keys, self.session
        g = self.guard
        queries = {
            "join": self._on_join,
            "leave": self._on_leave,
            "clock": self._on_clock,
            "snapshot": self._on_snapshot,
            "configs": self._on_configs,
            "map": self._on_map,
            "scenario": self._on_scenario,
        }
        for name, handler in queries.items():
            self._entities.append(s.declare_queryable(k.authority(name), g.query(name, handler)))
        poses = s.declare_subscriber(k.all_ego("pose"), zenoh.handlers.RingChannel(RING_CAPACITY))
        self._entities.append(poses)
        self._intake = PoseIntake(poses, self.drops)
        self._intake.routes.attach(s, name="authority-pose-routes")
        if self.settings.digest_period_s > 0:
            self.digest = PoseDigestRelay(
                s, k, self._intake, self.drops, s.new_timestamp, self.settings.digest_period_s
            ).start()
        state = g.sample("state", self._on_state)
        self._entities.append(s.declare_subscriber(k.all_ego("state"), state))
        presence = g.sample("presence", self._on_presence)
        self._entities.append(
            s.liveliness().declare_subscriber(k.all_nodes, presence, history=True)
        )
        # Declared last: nodes re-join when they see it, so the queryables must be up first.
        self._token = s.liveliness().declare_token(k.node(AUTHORITY_ID))
        return self

    def run(self, duration_s: float | None = None) -> None:
        """Tick at the configured rate until stop() or the duration has passed."""
        period = 1.0 / self.settings.tick_hz
        if self.settings.tick_priority:
            self.scheduling = raise_priority(self.settings.tick_priority)  # this thread's
        # Everything alive now lives as long as the session (the map, the scenario, the
        # network's tables): out of the collector's sight, a full collection no longer walks
        # it while a tick waits (up to 124 ms at N = 256 on a loaded host before).
        gc.freeze()
        try:
            self._run(period, duration_s)
        finally:
            gc.unfreeze()

    def _run(self, period: float, duration_s: float | None) -> None:
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
        if self.digest is not None:
            self.digest.close()
            self.digest = None
        # The reverse of start(): queryables go before the token. A node that hears the
        # token's DELETE asks to join again at once; were the join queryable still up, this
        # closing authority would accept it and the node would stay joined to no one.
        for entity in self._entities:
            entity.undeclare()  # type: ignore[attr-defined]
        self._entities.clear()
        if self._intake is not None:
            self._intake.routes.close()
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        self.domain.close()

    @property
    def dropped(self) -> dict[str, int]:
        """Undecodable payloads by key, and refused-but-well-formed ones as `<key>/<why>`."""
        return {**self.drops.snapshot(), **self.rejected.snapshot()}

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
        poses = self._intake.drain() if self._intake is not None else []
        rx_t = self.clock.now()
        with self._lock:
            self._apply_poses(poses, rx_t)
            gone = _drain(self._gone)
            gone += [(n, "timeout") for n in self.roster.expired(t)]
            for node_id, reason in gone:
                self._despawn(node_id, reason, t)
            tracks = dict(self.roster.tracks)
        for event in _drain(self._spawned):
            self.outbox.event(msgspec.structs.replace(event, seq=self.outbox.next_seq(), t=t))
        self.domain.tick(t, tracks, self.outbox)

    def _apply_poses(self, poses: list[tuple[str, m.Pose]], rx_t: float) -> None:
        for node_id, pose in poses:
            refused = self.roster.pose(node_id, pose, rx_t)
            if refused:
                self.rejected.add(f"pose/{refused}")

    def _despawn(self, node_id: str, reason: m.DespawnReason, t: float) -> None:
        if self.roster.remove(node_id) is None:
            return
        self.despawned.append((node_id, reason))
        del self.despawned[:-DESPAWN_LOG]
        log.info("despawn %s (%s)", node_id, reason)
        self.domain.ego_left(node_id)
        self.outbox.forget(node_id)
        self.outbox.event(m.Despawned(self.outbox.next_seq(), t, node_id, reason))

    # ------------------------------------------------------------ subscriptions

    def _on_state(self, sample: zenoh.Sample) -> None:
        try:
            node_id = parse(str(sample.key_expr)).node_id
            state = m.EGO_STATE.decode(sample.payload.to_bytes())
        except (KeySpaceError, m.MessageError):
            self.drops.add("state")
            return
        with self._lock:
            track = self.roster.tracks.get(node_id)
            if track is not None:
                track.info = msgspec.structs.replace(track.info, state=state)
            else:
                self.rejected.add("state/not_joined")

    def _on_presence(self, sample: zenoh.Sample) -> None:
        try:
            node_id = parse(str(sample.key_expr)).node_id
        except KeySpaceError:
            self.drops.add("presence")
            return
        if node_id == AUTHORITY_ID:
            return
        with self._lock:
            if self.roster.token(node_id, sample.kind == zenoh.SampleKind.PUT):
                self._gone.append((node_id, "liveliness"))

    # ------------------------------------------------------------ queries

    def _request(self, query: zenoh.Query, what: str) -> object | None:
        """The query's request decoded, or None after an error reply naming the problem."""
        try:
            payload = query.payload
            return m.REQUEST_CODECS[what].decode(payload.to_bytes() if payload else b"")
        except m.MessageError as exc:
            self.drops.add(what)
            reply_err(query, f"bad {what} request: {exc}")
            return None

    def _on_join(self, query: zenoh.Query) -> None:
        if self._stop.is_set():
            return  # closing: no reply, so the node asks again and finds the next authority
        req = self._request(query, "join")
        if not isinstance(req, m.JoinRequest):
            return
        with self._lock:
            decision = self.roster.join(req, self.clock.now())
            if decision.accepted and decision.new and decision.track is not None:
                self._announce_join(req, decision.replaced, decision.track)
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
            pose_digest_s=self.settings.digest_period_s,
        )
        if not decision.accepted:
            self.rejected.add("join/refused")
            self.guard.log.warning("join", "refused join of %r: %s", req.node_id, decision.reason)
        query.reply(query.key_expr, m.JOIN_REPLY.encode(reply))

    def _announce_join(self, req: m.JoinRequest, replaced: bool, track: EgoTrack) -> None:
        """Queue the events of an accepted first join for the tick (t and seq set there)."""
        if replaced:  # another process held the id and is gone: the authority removes it
            self.domain.ego_left(req.node_id)
            self._spawned.append(m.Despawned(0, 0.0, req.node_id, "authority"))
        self.domain.ego_joined(track)
        self._spawned.append(m.Spawned(0, 0.0, req.node_id, req.kind, req.actor_kind))

    def _on_leave(self, query: zenoh.Query) -> None:
        req = self._request(query, "leave")
        if not isinstance(req, m.LeaveRequest):
            return
        with self._lock:
            track = self.roster.tracks.get(req.node_id)
            left = track is not None and track.instance == req.instance
            if left:
                self._gone.append((req.node_id, "left"))
            else:
                self.rejected.add("leave/unknown_instance")
        query.reply(query.key_expr, m.LEAVE_REPLY.encode(m.LeaveReply(left)))

    def _on_clock(self, query: zenoh.Query) -> None:
        t = self.clock.now()  # first, so the reply's time is as close to the answer as can be
        req = self._request(query, "clock")
        if not isinstance(req, m.ClockRequest):
            return
        known = req.node_id in self.roster.tracks
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
    pose = None if track.last_pose is None else m.encode_pose(track.last_pose)
    return msgspec.structs.replace(track.info, pose_wire=pose)


def _drain(queue: deque) -> list:
    """Everything in a deque that callbacks append to, oldest first."""
    out = []
    while queue:
        out.append(queue.popleft())
    return out
