"""The viewer's model of a session: actors, map, lights, weather, events and node statistics.

Fed by `Batch`es from the `SampleStore` (live) or by recorded samples (playback), on the
render thread only. It decodes, validates (bad payloads are counted per key and dropped) and
marks what changed, so the scene logs only that.
"""

from __future__ import annotations

import logging
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field

from carlaverse import messages as m
from carlaverse.viz.store import Batch, Sample

log = logging.getLogger(__name__)

TRAIL_EGO = 600  # points kept per ego trail (30 s at 20 Hz)
TRAIL_NPC = 40  # points kept per NPC trail (2 s at 20 Hz)
DEFAULT_EXTENT = m.Extent()


@dataclass(slots=True)
class Actor:
    id: str
    ego: bool
    kind: str  # one of messages.ACTOR_KINDS
    extent: m.Extent
    t: float = 0.0  # [s] session time of the pose
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad] roll, pitch, yaw
    trail: deque[tuple[float, float, float]] = field(default_factory=deque)
    rx_t: float = 0.0  # [s] local time of the last sample
    dirty: bool = True

    def move(
        self, t: float, xyz: tuple[float, float, float], rpy: tuple[float, float, float]
    ) -> None:
        self.t, self.xyz, self.rpy, self.dirty = t, xyz, rpy, True
        self.trail.append(xyz)


@dataclass(slots=True)
class NodeStats:
    """Per-node stream health: pose rate and the one-way latency of the latest pose."""

    samples: int = 0
    window_start: float = 0.0  # [s] local
    rate_hz: float | None = None
    latency_s: float | None = None


@dataclass(frozen=True, slots=True)
class Event:
    t: float  # [s] session time
    text: str
    level: str = "INFO"


class WorldModel:
    """Latest decoded state of a session, with change flags for the scene logger."""

    def __init__(self, latency_of: Callable[[float, float], float | None] | None = None) -> None:
        # latency_of(rx_t, msg_t) -> one-way latency [s], or None when clocks are not comparable
        self._latency_of = latency_of
        self.map: m.MapReply | None = None
        self.map_dirty = False
        self.egos: dict[str, Actor] = {}
        self.npcs: dict[str, Actor] = {}
        self.lights: m.LightsState | None = None
        self.lights_dirty = False
        self.weather: m.Weather | None = None
        self.weather_dirty = False
        self.impulses: list[tuple[str, m.Impulse]] = []
        self.events: list[Event] = []
        self.removed: list[tuple[str, bool, float]] = []  # (actor id, is ego, session time)
        self.nodes: dict[str, NodeStats] = {}
        self.session_t = 0.0  # [s] the newest session time any message carried
        self.newcomers = False  # an ego appeared: the viewer asks for a snapshot (extents)
        self.bad: Counter[str] = Counter()
        self.dropped_events = 0

    # ------------------------------------------------------------------ intake

    def apply(self, batch: Batch) -> None:
        self.dropped_events += batch.dropped_events
        for sample in batch.samples():
            self.apply_sample(sample)
        for key, n in batch.counts.items():  # rates count every pose, not just the kept ones
            if key.area == "ego" and key.channel == "pose" and key.node_id in self.nodes:
                self.nodes[key.node_id].samples += n

    def apply_sample(self, sample: Sample) -> None:
        key = sample.key
        codec = m.CHANNEL_CODECS.get((key.area, key.channel))
        if key.area == "node":
            self._presence(key.node_id, sample)
            return
        if codec is None or sample.kind != "put":
            return
        try:
            msg = codec.decode(sample.payload)
        except m.MessageError as exc:
            self.bad[key.path] += 1
            log.debug("dropping a bad %s payload: %s", key.path, exc)
            return
        self._dispatch(key.node_id, msg, sample.rx_t)

    def _dispatch(self, node_id: str, msg: object, rx_t: float) -> None:
        t = getattr(msg, "t", None)
        if isinstance(t, float) and not isinstance(msg, m.Snapshot | m.ClockReply):
            self.session_t = max(self.session_t, t)
        if isinstance(msg, m.Pose):
            self._pose(node_id, msg, rx_t)
        elif isinstance(msg, m.NpcBatch):
            self._npcs(msg, rx_t)
        elif isinstance(msg, m.LightsState):
            self.lights, self.lights_dirty = msg, True
        elif isinstance(msg, m.Weather):
            self.weather, self.weather_dirty = msg, True
        elif isinstance(msg, m.Impulse):
            self.impulses.append((node_id, msg))
        elif isinstance(msg, m.Spawned | m.Despawned | m.ContactStarted | m.ContactEnded):
            self._event(msg)
        elif isinstance(msg, m.MapReply):
            self.map, self.map_dirty = msg, True
        elif isinstance(msg, m.Snapshot):
            self._snapshot(msg, rx_t)

    # ------------------------------------------------------------------ actors

    def _ego(self, node_id: str) -> Actor:
        actor = self.egos.get(node_id)
        if actor is None:
            actor = Actor(node_id, True, "car", DEFAULT_EXTENT, trail=deque(maxlen=TRAIL_EGO))
            self.egos[node_id] = actor
            self.newcomers = True
        return actor

    def _pose(self, node_id: str, pose: m.Pose, rx_t: float) -> None:
        actor = self._ego(node_id)
        if pose.t < actor.t:
            return  # an older sample overtaken by a newer one
        actor.move(pose.t, (pose.x, pose.y, pose.z), (pose.roll, pose.pitch, pose.yaw))
        actor.rx_t = rx_t
        stats = self.nodes.setdefault(node_id, NodeStats(window_start=rx_t))
        if self._latency_of is not None:
            stats.latency_s = self._latency_of(rx_t, pose.t)

    def _npcs(self, batch: m.NpcBatch, rx_t: float) -> None:
        try:
            rows = batch.array()
        except ValueError:
            self.bad["world/npc"] += 1
            return
        if len(rows) != len(batch.ids):
            self.bad["world/npc"] += 1
            return
        seen = set()
        for npc_id, row in zip(batch.ids, rows.tolist(), strict=True):
            seen.add(npc_id)
            self._npc(npc_id, row, batch.t, rx_t)
        for gone in set(self.npcs) - seen:
            del self.npcs[gone]
            self.removed.append((gone, False, batch.t))

    def _npc(self, npc_id: str, row: tuple, t: float, rx_t: float) -> None:
        x, y, z, yaw, _vx, _vy, _wz, length, width, height, kind, _r, _lights = row
        actor = self.npcs.get(npc_id)
        if actor is None:
            kind_name = m.ACTOR_KINDS[kind] if kind < len(m.ACTOR_KINDS) else "other"
            extent = m.Extent(length, width, height)
            actor = Actor(npc_id, False, kind_name, extent, trail=deque(maxlen=TRAIL_NPC))
            self.npcs[npc_id] = actor
        actor.move(t, (x, y, z), (0.0, 0.0, yaw))
        actor.rx_t = rx_t

    def _snapshot(self, snap: m.Snapshot, rx_t: float) -> None:
        for info in snap.egos:
            if not info.actor_kind:
                continue  # an observer: a member of the session without a body
            if info.node_id not in self.egos and info.pose is None:
                continue  # nowhere to draw it yet; its first pose will create it
            actor = self._ego(info.node_id)
            actor.extent = info.extent
            actor.kind = info.actor_kind if info.actor_kind in m.ACTOR_KINDS else "other"
            actor.dirty = True
            if info.pose is not None and info.pose.t >= actor.t:
                self._pose(info.node_id, info.pose, rx_t)
        if snap.lights is not None and self.lights is None:
            self.lights, self.lights_dirty = snap.lights, True
        if snap.weather is not None and self.weather is None:
            self.weather, self.weather_dirty = snap.weather, True

    def _presence(self, node_id: str, sample: Sample) -> None:
        if sample.kind == "delete":
            self._remove_ego(node_id, self.session_t, "left (liveliness lost)")

    def _event(self, event: m.WorldEvent) -> None:
        if isinstance(event, m.Spawned):
            self.events.append(Event(event.t, f"spawned {event.node_id} ({event.kind})"))
            self.newcomers = True
        elif isinstance(event, m.Despawned):
            self._remove_ego(event.node_id, event.t, f"despawned: {event.reason}")
        elif isinstance(event, m.ContactStarted):
            speed = event.relative_speed_mps
            text = f"contact {event.contact_id}: {event.a} × {event.b} at {speed:.1f} m/s"
            self.events.append(Event(event.t, text, "WARN"))
        else:
            self.events.append(Event(event.t, f"contact {event.contact_id} ended"))

    def _remove_ego(self, node_id: str, t: float, why: str) -> None:
        if self.egos.pop(node_id, None) is not None:
            self.removed.append((node_id, True, t))
            self.events.append(Event(t, f"{node_id} {why}"))

    def expire(self, now_rx: float, timeout_s: float) -> None:
        """Drop egos silent for `timeout_s` (no ghost actors when a node vanishes)."""
        for node_id, actor in list(self.egos.items()):
            if now_rx - actor.rx_t > timeout_s:
                self._remove_ego(node_id, self.session_t, f"silent for {timeout_s:g} s")

    def update_rates(self, now_rx: float, window_s: float = 1.0) -> None:
        """Close a rate window per node once it is `window_s` old."""
        for stats in self.nodes.values():
            span = now_rx - stats.window_start
            if span >= window_s:
                stats.rate_hz = stats.samples / span
                stats.samples, stats.window_start = 0, now_rx
