"""The viewer's model of a session around its actors: map, lights, weather, events, stats.

Fed by `Batch`es from the `SampleStore` (live) or by recorded samples (playback), on the
render thread only. It decodes, validates (bad payloads are counted per key and dropped) and
marks what changed, so the scene logs only that.

Where actors are drawn is the `WorldView`'s business (one render time per view), not
this model's: pose and NPC streams go straight into the view (`raw.ActorFeed`). The model hands
the view what decides membership — presence tokens, spawn and despawn events, snapshots — in
receive order, through the same `SampleFeed` and decoded once, and keeps what the view does
not: each ego's kind and extent (from snapshots).
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from carlaverse import messages as m
from carlaverse.viz.store import Batch, Sample
from carlaverse.world.source import SampleFeed

log = logging.getLogger(__name__)

DEFAULT_EXTENT = m.Extent()
# Distinct nodes with stream statistics, and keys with bad payloads counted by name, at most
# (the recorder's channel bound): past it, counted together under OTHERS.
COUNTED_LIMIT = 4096
OTHERS = "(other keys)"


@dataclass(frozen=True, slots=True)
class ActorLook:
    """How an actor is drawn: its kind (one of messages.ACTOR_KINDS, or "other") and extent."""

    kind: str = "car"
    extent: m.Extent = DEFAULT_EXTENT


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

    def __init__(
        self,
        view: SampleFeed | None = None,
        latency_of: Callable[[float, float], float | None] | None = None,
    ) -> None:
        self.view = view  # into the world view: who is present; None: no actors (tests)
        # latency_of(rx_t, msg_t) -> one-way latency [s], or None when clocks are not comparable
        self._latency_of = latency_of
        self.map: m.MapReply | None = None
        self.map_dirty = False
        self.looks: dict[str, ActorLook] = {}  # ego id -> kind and extent, from snapshots
        self.lights: m.LightsState | None = None
        self.lights_dirty = False
        self.weather: m.Weather | None = None
        self.weather_dirty = False
        self.impulses: list[tuple[str, m.Impulse]] = []
        self.events: list[Event] = []
        self.nodes: dict[str, NodeStats] = {}
        self.session_t = 0.0  # [s] the newest session time any message carried
        self.newcomers = False  # an ego without a known look: the viewer asks for a snapshot
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
            self._presence(sample)
            return
        if codec is None or sample.kind != "put" or (key.area, key.channel) == ("world", "npc"):
            return  # NPC batches go to the view as they come (`raw.ActorFeed`)
        try:
            msg = codec.decode(sample.payload)
        except m.MessageError as exc:
            # per key, up to a bound: anyone may invent keys (node ids) to send garbage on
            path = key.path if key.path in self.bad or len(self.bad) < COUNTED_LIMIT else OTHERS
            self.bad[path] += 1
            log.debug("dropping a bad %s payload: %s", key.path, exc)
            return
        if self.view is not None and isinstance(msg, m.Snapshot | m.Spawned | m.Despawned):
            self.view.hand(key, msg, sample.rx_t)  # membership, in receive order
        self._dispatch(key.node_id, msg, sample.rx_t)

    def _dispatch(self, node_id: str, msg: object, rx_t: float) -> None:
        t = getattr(msg, "t", None)
        if isinstance(t, float) and not isinstance(msg, m.Snapshot | m.ClockReply):
            self.session_t = max(self.session_t, t)
        if isinstance(msg, m.Pose):
            self._pose(node_id, msg, rx_t)
        elif isinstance(msg, m.LightsState):
            self.lights, self.lights_dirty = msg, True
        elif isinstance(msg, m.Weather):
            self.weather, self.weather_dirty = msg, True
        elif isinstance(msg, m.Impulse):
            self.impulses.append((node_id, msg))
        elif isinstance(msg, m.Spawned | m.Despawned | m.ContactStarted | m.ContactEnded):
            self._event(msg, rx_t)
        elif isinstance(msg, m.MapReply):
            self.map, self.map_dirty = msg, True
        elif isinstance(msg, m.Snapshot):
            self._snapshot(msg, rx_t)

    # ------------------------------------------------------------------ actors

    def _pose(self, node_id: str, pose: m.Pose, rx_t: float) -> None:
        """Stream health only: the view draws the actor from its own copy of the stream."""
        if node_id not in self.looks:
            self.newcomers = True  # learn its kind and extent
        stats = self.nodes.get(node_id)
        if stats is None:
            if len(self.nodes) >= COUNTED_LIMIT:  # ids past the bound: invented, or a huge run
                self.bad[OTHERS] += 1
                return
            stats = self.nodes[node_id] = NodeStats(window_start=rx_t)
        if self._latency_of is not None:
            stats.latency_s = self._latency_of(rx_t, pose.t)

    def _snapshot(self, snap: m.Snapshot, rx_t: float) -> None:
        for info in snap.egos:
            if not info.actor_kind:
                continue  # an observer: a member of the session without a body
            kind = info.actor_kind if info.actor_kind in m.ACTOR_KINDS else "other"
            self.looks[info.node_id] = ActorLook(kind, info.extent)
        if snap.lights is not None and self.lights is None:
            self.lights, self.lights_dirty = snap.lights, True
        if snap.weather is not None and self.weather is None:
            self.weather, self.weather_dirty = snap.weather, True

    def _presence(self, sample: Sample) -> None:
        if self.view is not None:
            self.view.route_parsed(sample.key, sample.kind, sample.payload, sample.rx_t)

    def _event(self, event: m.WorldEvent, rx_t: float) -> None:
        if isinstance(event, m.Spawned):
            self.events.append(Event(event.t, f"spawned {event.node_id} ({event.kind})"))
            self.newcomers = True
        elif isinstance(event, m.ContactStarted):
            speed = event.relative_speed_mps
            text = f"contact {event.contact_id}: {event.a} × {event.b} at {speed:.1f} m/s"
            self.events.append(Event(event.t, text, "WARN"))
        elif isinstance(event, m.ContactEnded):
            self.events.append(Event(event.t, f"contact {event.contact_id} ended"))
        # a despawn: the view reports the removal (with its reason) when it applies it

    def update_rates(self, now_rx: float, window_s: float = 1.0) -> None:
        """Close a rate window per node once it is `window_s` old."""
        for stats in self.nodes.values():
            span = now_rx - stats.window_start
            if span < 0:  # the session clock stepped back (first sync): start a new window
                stats.samples, stats.window_start = 0, now_rx
            elif span >= window_s:
                stats.rate_hz = stats.samples / span
                stats.samples, stats.window_start = 0, now_rx
