"""NodeClient: everything a node does on the fabric, behind one object (DESIGN §6).

    session = open_session(settings.fabric)
    client = NodeClient(session, settings.node, MonotonicClock())
    client.start(pose_source=lambda t: my_pose_at(t))
    ...
    now = client.update()            # on the node's own loop: apply what arrived
    for view in client.world.ego_views(now): draw(view)
    client.close()

Threads: Zenoh's callbacks decode and enqueue, never wait; a publisher thread sends the ego
pose at the configured rate; a control thread joins (and re-joins after an authority restart
or a partition), keeps the session clock in sync, and nothing else. The node's own control
loop never calls into Zenoh.
"""

from __future__ import annotations

import logging
import socket
import threading
import uuid
from collections import Counter, deque
from collections.abc import Callable

import msgspec
import zenoh

from carlaverse import __version__
from carlaverse import messages as m
from carlaverse.config import StrictStruct
from carlaverse.fabric.clock import Clock, SessionClock
from carlaverse.fabric.remote_actor import InterpolationSettings
from carlaverse.fabric.world_view import WorldView
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, check_token, parse

log = logging.getLogger(__name__)

PoseSource = Callable[[float], m.Pose | None]


class JoinRefused(RuntimeError):
    """The authority refused this node (a duplicate id, a schema mismatch)."""


class NodeSettings(StrictStruct):
    node_id: str = ""  # required; may come from --id instead of the file
    session: str = "default"
    kind: str = "scripted"
    actor_kind: str = "car"
    extent: m.Extent = m.Extent()
    mass_kg: float = 1500.0
    site: str = ""
    pose_rate_hz: float = 50.0
    join_retry_s: float = 0.5
    join_timeout_s: float = 2.0
    clock_sync_period_s: float = 2.0
    interpolation: InterpolationSettings = InterpolationSettings()


class NodeClient:
    def __init__(
        self,
        session: zenoh.Session,
        settings: NodeSettings,
        clock: Clock,
        config_yaml: str = "",
    ) -> None:
        check_token(settings.node_id)
        if settings.node_id == AUTHORITY_ID:
            raise JoinRefused(f"node id {AUTHORITY_ID!r} is reserved for the authority")
        self.session = session
        self.settings = settings
        self.keys = Keys(settings.session)
        self.clock = SessionClock(clock)
        self.instance = uuid.uuid4().hex
        self.config_yaml = config_yaml
        self.world = WorldView(settings.node_id, settings.interpolation)
        self.impulses: deque[m.Impulse] = deque(maxlen=256)
        self.overrides: deque[m.Override] = deque(maxlen=64)
        self.dropped: Counter[str] = Counter()
        self.joined = threading.Event()  # accepted by the current authority
        self.admitted = threading.Event()  # accepted at least once: poses may flow
        self.refused: str | None = None
        self._settled = threading.Event()  # the first join was answered, yes or no
        self.join_reply: m.JoinReply | None = None
        self.snapshot: m.Snapshot | None = None
        self.joins = 0
        self.poses_sent = 0
        self._seq = 0
        self._state_seq = 0
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._token: zenoh.LivelinessToken | None = None
        self._entities: list[object] = []
        self._threads: list[threading.Thread] = []
        self._pose_pub = session.declare_publisher(
            self.keys.pose(settings.node_id),
            congestion_control=zenoh.CongestionControl.DROP,
            priority=zenoh.Priority.REAL_TIME,  # ahead of NPC batches and bulk under load
            # Our own `ego/*/pose` subscriber would otherwise get each put delivered in the
            # publishing thread, running a Python callback before the sample leaves.
            allowed_destination=zenoh.Locality.REMOTE,
        )
        self._state_pub = session.declare_publisher(
            self.keys.state(settings.node_id),
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )

    @property
    def node_id(self) -> str:
        return self.settings.node_id

    def now(self) -> float:
        """Session time [s]."""
        return self.clock.now()

    # ------------------------------------------------------------ lifecycle

    def start(self, pose_source: PoseSource | None = None) -> NodeClient:
        self._subscribe()
        self._spawn(self._control_loop, "control")
        if pose_source is not None:
            self._spawn(lambda: self._publish_loop(pose_source), "pose")
        return self

    def wait_joined(self, timeout: float) -> bool:
        """Block until accepted; raise JoinRefused if the authority said no."""
        if not self._settled.wait(timeout):
            return False
        if self.refused is not None:
            raise JoinRefused(self.refused)
        return True

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        for thread in self._threads:
            thread.join(timeout=3)
        if self._token is not None:
            self._token.undeclare()  # peers and the authority despawn us at once
            self._token = None
        for entity in self._entities:
            entity.undeclare()  # type: ignore[attr-defined]
        self._entities.clear()

    def _spawn(self, target: Callable[[], None], name: str) -> None:
        thread = threading.Thread(target=target, name=f"{self.node_id}-{name}", daemon=True)
        thread.start()
        self._threads.append(thread)

    # ------------------------------------------------------------ publishing

    def publish_pose(self, pose: m.Pose) -> bool:
        """Send one pose sample now (sequence number assigned here); never blocks."""
        if not self.admitted.is_set():
            return False
        self._seq += 1
        self._pose_pub.put(m.encode_pose(msgspec.structs.replace(pose, seq=self._seq)))
        self.poses_sent += 1
        return True

    def publish_state(self, state: m.EgoState) -> None:
        self._state_seq += 1
        payload = m.EGO_STATE.encode(msgspec.structs.replace(state, seq=self._state_seq))
        self._state_pub.put(payload)

    def _publish_loop(self, source: PoseSource) -> None:
        period = 1.0 / self.settings.pose_rate_hz
        local = self.clock.local
        next_t = local.now()
        while not self._stop.is_set():
            try:
                pose = source(self.now())
                if pose is not None:
                    self.publish_pose(pose)
            except Exception:  # a broken source must not kill presence; say so loudly
                self.dropped["pose_source"] += 1
                log.exception("pose source of %s failed", self.node_id)
            next_t += period
            delay = next_t - local.now()
            if delay < -period:  # fell behind (suspended?): do not burst to catch up
                next_t, delay = local.now(), 0.0
            self._stop.wait(max(0.0, delay))

    # ------------------------------------------------------------ world updates

    def update(self) -> float:
        """Apply everything received; return the session time it was applied at."""
        now = self.now()
        self.world.update(now)
        return now

    # ------------------------------------------------------------ subscriptions

    def _subscribe(self) -> None:
        k, s = self.keys, self.session
        remote = zenoh.Locality.REMOTE
        self._entities += [
            s.declare_subscriber(k.all_ego("pose"), self._on_pose, allowed_origin=remote),
            s.declare_subscriber(k.all_ego("state"), self._on_state),
            s.declare_subscriber(k.override(self.node_id), self._on_override),
            s.declare_subscriber(k.world("npc"), self._on_npc),
            s.declare_subscriber(k.world("lights"), self._on_lights),
            s.declare_subscriber(k.world("weather"), self._on_weather),
            s.declare_subscriber(k.world("events"), self._on_event),
            s.declare_subscriber(k.impulse(self.node_id), self._on_impulse),
            s.liveliness().declare_subscriber(k.all_nodes, self._on_presence, history=True),
        ]

    def _decode(self, sample: zenoh.Sample, codec: m.Codec, channel: str) -> object | None:
        try:
            return codec.decode(sample.payload.to_bytes())
        except m.MessageError as exc:
            self.dropped[channel] += 1
            log.debug("dropped %s on %s: %s", channel, sample.key_expr, exc)
            return None

    def _sender(self, sample: zenoh.Sample, channel: str) -> str | None:
        try:
            return parse(str(sample.key_expr)).node_id
        except KeySpaceError:
            self.dropped[channel] += 1
            return None

    def _on_pose(self, sample: zenoh.Sample) -> None:
        rx_t = self.now()
        node_id = self._sender(sample, "pose")
        pose = self._decode(sample, m.POSE, "pose")
        if node_id is not None and pose is not None:
            self.world.push_pose(node_id, pose, rx_t)  # type: ignore[arg-type]

    def _on_state(self, sample: zenoh.Sample) -> None:
        node_id = self._sender(sample, "state")
        state = self._decode(sample, m.EGO_STATE, "state")
        if node_id is not None and state is not None:
            self.world.inbox.append(("state", node_id, state))

    def _on_override(self, sample: zenoh.Sample) -> None:
        override = self._decode(sample, m.OVERRIDE, "override")
        if override is not None:
            self.overrides.append(override)  # type: ignore[arg-type]

    def _on_npc(self, sample: zenoh.Sample) -> None:
        rx_t = self.now()
        batch = self._decode(sample, m.NPC_BATCH, "npc")
        if batch is None:
            return
        if len(batch.rows) != len(batch.ids) * m.NPC_DTYPE.itemsize:  # type: ignore[attr-defined]
            self.dropped["npc"] += 1
            return
        self.world.push_npc(batch, rx_t)  # type: ignore[arg-type]

    def _on_lights(self, sample: zenoh.Sample) -> None:
        lights = self._decode(sample, m.LIGHTS, "lights")
        if lights is not None:
            self.world.lights = lights  # type: ignore[assignment]

    def _on_weather(self, sample: zenoh.Sample) -> None:
        weather = self._decode(sample, m.WEATHER, "weather")
        if weather is not None:
            self.world.weather = weather  # type: ignore[assignment]

    def _on_event(self, sample: zenoh.Sample) -> None:
        event = self._decode(sample, m.WORLD_EVENT, "events")
        if isinstance(event, m.Despawned):
            if event.node_id == self.node_id:
                self.joined.clear()  # the authority dropped us (a partition): join again
                self._wake.set()
            else:
                self.world.push_gone(event.node_id, event.reason, self.now())
        elif isinstance(event, m.Spawned):
            self.world.push_present(event.node_id)

    def _on_impulse(self, sample: zenoh.Sample) -> None:
        impulse = self._decode(sample, m.IMPULSE, "impulse")
        if impulse is not None:
            self.impulses.append(impulse)  # type: ignore[arg-type]

    def _on_presence(self, sample: zenoh.Sample) -> None:
        node_id = self._sender(sample, "presence")
        if node_id is None:
            return
        alive = sample.kind == zenoh.SampleKind.PUT
        if node_id == AUTHORITY_ID:
            if alive:
                self.clock.reset()
            self.joined.clear()  # a new authority knows nothing of us; a gone one neither
            self._wake.set()
        elif node_id != self.node_id:
            if alive:
                self.world.push_present(node_id)
            else:
                self.world.push_gone(node_id, "liveliness", self.now())

    # ------------------------------------------------------------ control thread

    def _control_loop(self) -> None:
        next_sync = 0.0
        local = self.clock.local
        while not self._stop.is_set():
            if not self.joined.is_set():
                self._try_join()
            if local.now() >= next_sync:
                burst = 8 if not self.clock.synced else 3
                for _ in range(burst):
                    self._sync_clock()
                next_sync = local.now() + self.settings.clock_sync_period_s
            if self.refused is not None:
                return
            joined = self.joined.is_set()
            wait = next_sync - local.now() if joined else self.settings.join_retry_s
            self._wake.wait(max(0.01, wait))
            self._wake.clear()

    def _query(self, key: str, payload: bytes, timeout: float) -> bytes | None:
        try:
            for reply in self.session.get(key, payload=payload, timeout=timeout):
                if reply.ok is not None:
                    return reply.ok.payload.to_bytes()
        except zenoh.ZError as exc:
            log.debug("query %s failed: %s", key, exc)
        return None

    def _try_join(self) -> None:
        s = self.settings
        request = m.JoinRequest(
            schema=m.SCHEMA_VERSION, node_id=s.node_id, instance=self.instance, kind=s.kind,
            actor_kind=s.actor_kind, extent=s.extent, mass_kg=s.mass_kg, site=s.site,
            hostname=socket.gethostname(), version=__version__, pose_rate_hz=s.pose_rate_hz,
            config_yaml=self.config_yaml,
        )  # fmt: skip
        payload = m.JOIN_REQUEST.encode(request)
        raw = self._query(self.keys.authority("join"), payload, s.join_timeout_s)
        if raw is None:
            return
        try:
            reply = m.JOIN_REPLY.decode(raw)
        except m.MessageError as exc:
            self.dropped["join"] += 1
            log.warning("unreadable join reply: %s", exc)
            return
        if not reply.accepted:
            self.refused = reply.reason
            log.error("join refused: %s", reply.reason)
            self._settled.set()
            return
        self.join_reply = reply
        self.joins += 1
        if self._token is None:
            self._token = self.session.liveliness().declare_token(self.keys.node(self.node_id))
        self.admitted.set()
        self.joined.set()
        self._settled.set()
        self._fetch_snapshot()
        log.info("joined session %s as %s (join #%d)", s.session, s.node_id, self.joins)

    def _fetch_snapshot(self) -> None:
        """Seed the world with everything present now, so a late joiner misses nothing."""
        raw = self._query(self.keys.authority("snapshot"), b"", self.settings.join_timeout_s)
        if raw is None:
            return
        try:
            snapshot = m.SNAPSHOT.decode(raw)
        except m.MessageError as exc:
            self.dropped["snapshot"] += 1
            log.warning("unreadable snapshot: %s", exc)
            return
        self.snapshot = snapshot
        self.world.inbox.append(("snapshot", snapshot, self.now()))

    def _sync_clock(self) -> None:
        local = self.clock.local
        payload = m.CLOCK_REQUEST.encode(m.ClockRequest(self.node_id))
        t0 = local.now()
        raw = self._query(self.keys.authority("clock"), payload, 0.5)
        t1 = local.now()
        if raw is None:
            return
        try:
            reply = m.CLOCK_REPLY.decode(raw)
        except m.MessageError:
            self.dropped["clock"] += 1
            return
        self.clock.add_exchange(t0, reply.t, t1)
        if not reply.known and self.joined.is_set() and self.refused is None:
            self.joined.clear()  # the authority lost us (restart, partition): join again
            self._wake.set()
