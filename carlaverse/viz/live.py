"""`carlaverse view` on a live session: a raw Zenoh observer feeding a fixed-rate render loop.

Three threads, none of which can slow the fabric:
- Zenoh callbacks copy the payload into the `SampleStore` (O(1), short lock); pose and NPC
  samples also go into the `WorldView`'s intake (a deque append: a pose's bytes as they came,
  an NPC batch decoded), stamped with their session receive time;
- a query thread keeps the session clock synchronised (first, so that receive times are
  session times) and asks the authority for the map (until it has one) and a snapshot (at
  start and whenever an ego of unknown kind appears);
- the caller's thread runs `run()`: every 1/rate s it takes what arrived, updates the model
  and the view (`update(now)`), and logs the actors where the view draws them — all at its
  one render time (`render_time(now)`). If a frame takes too long the next ones are skipped,
  not queued.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Any

import zenoh

from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, Keys
from carlaverse.transport.clock import Clock, MonotonicClock, SessionClock
from carlaverse.viz.model import WorldModel
from carlaverse.viz.raw import ActorFeed
from carlaverse.viz.scene import SceneLogger
from carlaverse.viz.store import SampleStore
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.source import SampleFeed
from carlaverse.world.world_view import WorldView

log = logging.getLogger(__name__)
VIEW_ID = "carlaverse-view"  # the view's own id in its WorldView: never a node id


def viewer_interpolation() -> InterpolationSettings:
    """A viewer draws where actors were, all at one time (`past`): what it shows is true at
    the time shown, which is what diagnosis needs; a driver needs `present` instead."""
    return InterpolationSettings(render_mode="past")


@dataclass(frozen=True, slots=True)
class ViewSettings:
    rate_hz: float = 20.0  # [Hz] render rate
    trails: bool = True
    # how actors are drawn, and when a silent one leaves the view (despawn_timeout_s)
    interpolation: InterpolationSettings = field(default_factory=viewer_interpolation)
    query_timeout_s: float = 2.0  # [s]
    clock_sync_s: float = 2.0  # [s] between session-clock queries
    map_retry_s: float = 2.0  # [s] between map queries until one is answered


@dataclass(slots=True)
class ViewStats:
    frames: int = 0
    skipped_frames: int = 0  # frames not rendered because the previous one overran
    samples: int = 0


class LiveView:
    """Observes `keys.session` on `session` and logs it through `scene`."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        scene: SceneLogger,
        settings: ViewSettings = ViewSettings(),
        local: Clock | None = None,
    ) -> None:
        self._session = session
        self._keys = keys
        self._scene = scene
        self._settings = settings
        self._local = local or MonotonicClock()
        self.clock = SessionClock(self._local)
        self.store = SampleStore()
        self.view = WorldView(VIEW_ID, settings.interpolation)
        samples = SampleFeed(self.view.intake)
        self.feed = ActorFeed(samples, scene.raw)
        self.world = WorldModel(samples, latency_of=self._latency)
        self.stats = ViewStats()
        self._want_snapshot = threading.Event()
        self._sync_now = threading.Event()  # an authority appeared: ask its clock now
        self._authority_key = keys.node(AUTHORITY_ID)
        self._stop_queries = threading.Event()
        self._handles: list[Any] = []
        self._query_thread = threading.Thread(target=self._query_loop, name="view-queries")

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> LiveView:
        keys, session = self._keys, self._session
        self._handles += [
            session.declare_subscriber(keys.everything, self._on_sample),
            session.declare_subscriber(keys.all_ego("pose"), self._on_actor_sample),
            session.declare_subscriber(keys.world("npc"), self._on_actor_sample),
        ]
        self._handles.append(
            self._session.liveliness().declare_subscriber(
                self._keys.all_nodes, self._on_presence, history=True
            )
        )
        self._query_thread.daemon = True
        self._query_thread.start()
        return self

    def close(self) -> None:
        self._stop_queries.set()
        for handle in self._handles:
            handle.undeclare()
        self._handles.clear()
        if self._query_thread.is_alive():
            self._query_thread.join(timeout=5)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh thread: copy and store, nothing more."""
        kind = "delete" if sample.kind == zenoh.SampleKind.DELETE else "put"
        self.store.offer(str(sample.key_expr), sample.payload.to_bytes(), self.clock.now(), kind)

    def _on_presence(self, sample: zenoh.Sample) -> None:
        """Zenoh thread: a presence token, stored; an authority's that appears may bring a new
        timeline (a looping replay's next pass), so the clock may step to it, as a node's
        does (`NodeClient`), and is synchronised at once."""
        self._on_sample(sample)
        if sample.kind == zenoh.SampleKind.PUT and str(sample.key_expr) == self._authority_key:
            self.clock.reset()
            self._sync_now.set()

    def _on_actor_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh thread: a pose or NPC batch into the view's intake (no waiting)."""
        self.feed.offer(str(sample.key_expr), sample.payload.to_bytes(), self.clock.now())

    def _latency(self, rx_t: float, msg_t: float) -> float | None:
        if not self.clock.synced:
            return None  # no offset measured yet: a number now would be a guess
        return rx_t - msg_t

    # ------------------------------------------------------------------ render loop

    def run(self, stop: threading.Event, duration_s: float | None = None) -> ViewStats:
        """Render at `rate_hz` until `stop` is set or `duration_s` passes."""
        period = 1.0 / self._settings.rate_hz
        start = self._local.now()
        next_frame = start
        while not stop.is_set():
            now = self._local.now()
            if duration_s is not None and now - start >= duration_s:
                break
            self.render_once(self.clock.now())
            next_frame += period
            after = self._local.now()
            if after > next_frame:  # overran: skip the frames we missed, do not catch up
                missed = int((after - next_frame) / period) + 1
                self.stats.skipped_frames += missed
                next_frame += missed * period
            stop.wait(max(0.0, next_frame - after))
        self.render_once(self.clock.now())
        return self.stats

    def render_once(self, now: float) -> None:
        """One frame at session time `now` [s]."""
        batch = self.store.take()
        self.stats.samples += sum(batch.counts.values())
        self.world.apply(batch)
        if self.world.newcomers:
            self.world.newcomers = False
            self._want_snapshot.set()  # learn the newcomer's extent and kind
        self.view.update(now)
        self.world.update_rates(now)
        self._scene.render(self.world, self.view, now)
        self.stats.frames += 1

    # ------------------------------------------------------------------ queries

    def _query_loop(self) -> None:
        s = self._settings
        next_sync = next_map = self._local.now()
        self._want_snapshot.set()
        while not self._stop_queries.is_set():
            now = self._local.now()
            if now >= next_sync or self._sync_now.is_set():  # first: receive times are
                self._sync_now.clear()  # session times once it is synced
                self._sync_clock()
                next_sync = now + s.clock_sync_s
            if self.world.map is None and now >= next_map:
                self._ask("map")
                next_map = now + s.map_retry_s
            if self._want_snapshot.is_set():
                self._want_snapshot.clear()
                self._ask("snapshot")
            self._stop_queries.wait(0.05)

    def _ask(self, name: str, payload: bytes | None = None) -> bytes | None:
        key = self._keys.authority(name)
        try:
            for reply in self._session.get(
                key, payload=payload, timeout=self._settings.query_timeout_s
            ):
                if reply.ok is not None:
                    data = reply.ok.payload.to_bytes()
                    if name != "clock":
                        self.store.offer(key, data, self.clock.now())
                    return data
        except zenoh.ZError as exc:
            log.warning("query %s failed: %s", key, exc)
        return None

    def _sync_clock(self) -> None:
        t0 = self._local.now()
        raw = self._ask("clock", m.CLOCK_REQUEST.encode(m.ClockRequest("")))
        t1 = self._local.now()
        if raw is None:
            return
        try:
            self.clock.add_exchange(t0, m.CLOCK_REPLY.decode(raw).t, t1)
        except m.MessageError as exc:
            log.warning("unreadable clock reply: %s", exc)
