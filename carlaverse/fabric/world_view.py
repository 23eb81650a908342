"""A node's picture of the world: remote egos and NPCs, lights and weather.

Zenoh callbacks only push into `inbox` (a deque append is atomic under the GIL, so they never
wait); the owner of the view drains it in `update(now)` on its own thread. That keeps every
`RemoteActor` single-threaded and the callbacks cheap.

No ghosts: an actor is removed when its presence token goes, when the authority announces its
despawn, or when it has been silent for the despawn timeout. A removed id is tombstoned so
that samples still in flight cannot resurrect it; its next appearance (token or spawn event)
lifts the tombstone.
"""

from __future__ import annotations

import logging
from collections import Counter, deque
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from carlaverse.fabric.remote_actor import ActorView, InterpolationSettings, RemoteActor
from carlaverse.fabric.stats import StreamStats
from carlaverse.messages import (
    ACTOR_KINDS,
    EgoState,
    LightsState,
    NpcBatch,
    Pose,
    Snapshot,
    Weather,
)

log = logging.getLogger(__name__)

INBOX_LIMIT = 100_000  # beyond this the owner is not draining; oldest input is dropped


@dataclass(frozen=True, slots=True)
class Despawn:
    actor_id: str
    reason: str
    t: float


class WorldView:
    def __init__(self, own_id: str, settings: InterpolationSettings) -> None:
        self.own_id = own_id
        self.settings = settings
        self.inbox: deque[tuple[Any, ...]] = deque(maxlen=INBOX_LIMIT)
        self.egos: dict[str, RemoteActor] = {}
        self.npcs: dict[str, RemoteActor] = {}
        self.ego_states: dict[str, EgoState] = {}
        self.lights: LightsState | None = None
        self.weather: Weather | None = None
        self.stats: dict[str, StreamStats] = {}
        self.despawns: list[Despawn] = []
        self.seen: set[str] = set()  # every ego id ever rendered
        self._tombstones: dict[str, float] = {}
        # Poses count only from nodes with a presence token (or announced by the authority):
        # a well-formed pose from a node that never joined is an intruder, not an actor.
        self.present: set[str] = set()
        self.rejected: Counter[str] = Counter()

    # ------------------------------------------------------------ called from callbacks

    def push_pose(self, node_id: str, pose: Pose, rx_t: float) -> None:
        if node_id != self.own_id:
            self.inbox.append(("pose", node_id, pose, rx_t))

    def push_npc(self, batch: NpcBatch, rx_t: float) -> None:
        self.inbox.append(("npc", batch, rx_t))

    def push_gone(self, node_id: str, reason: str, t: float) -> None:
        self.inbox.append(("gone", node_id, reason, t))

    def push_present(self, node_id: str) -> None:
        self.inbox.append(("present", node_id))

    # ------------------------------------------------------------ owner thread

    def update(self, now: float) -> None:
        """Apply everything received so far, then expire silent actors."""
        inbox = self.inbox
        while inbox:
            item = inbox.popleft()
            getattr(self, f"_on_{item[0]}")(*item[1:])
        for actor_id, actor in list(self.egos.items()):
            if actor.is_expired(now):
                self._remove(actor_id, "timeout", now)
        for npc_id, actor in list(self.npcs.items()):
            if actor.is_expired(now):
                del self.npcs[npc_id]

    def _on_pose(self, node_id: str, pose: Pose, rx_t: float) -> None:
        stats = self.stats.get(node_id)
        if stats is None:
            stats = self.stats[node_id] = StreamStats()
        stats.add(pose.seq, pose.t, rx_t)
        if node_id in self._tombstones or node_id not in self.present:
            self.rejected["pose_from_absent_node"] += 1
            return
        actor = self.egos.get(node_id)
        if actor is None:
            actor = self.egos[node_id] = RemoteActor(node_id, self.settings)
            self.seen.add(node_id)
        actor.add(pose, rx_t)

    def _on_npc(self, batch: NpcBatch, rx_t: float) -> None:
        rows = batch.array()
        present = set(batch.ids)
        for npc_id in [i for i in self.npcs if i not in present]:
            del self.npcs[npc_id]
        for npc_id, row in zip(batch.ids, rows, strict=False):
            actor = self.npcs.get(npc_id)
            if actor is None:
                kind = ACTOR_KINDS[row["kind"]] if row["kind"] < len(ACTOR_KINDS) else "other"
                actor = self.npcs[npc_id] = RemoteActor(npc_id, self.settings, kind)
            actor.add(_npc_pose(batch, row), rx_t)

    def _on_snapshot(self, snapshot: Snapshot, rx_t: float) -> None:
        self.lights = self.lights or snapshot.lights
        self.weather = self.weather or snapshot.weather
        if snapshot.npc is not None and not self.npcs:
            self._on_npc(snapshot.npc, rx_t)
        for ego in snapshot.egos:
            if ego.node_id == self.own_id or ego.node_id in self._tombstones:
                continue
            self.present.add(ego.node_id)
            if ego.state is not None:
                self.ego_states.setdefault(ego.node_id, ego.state)
            if ego.pose is not None and ego.node_id not in self.egos:
                actor = self.egos[ego.node_id] = RemoteActor(
                    ego.node_id, self.settings, ego.actor_kind
                )
                self.seen.add(ego.node_id)
                actor.add(ego.pose, rx_t)

    def _on_state(self, node_id: str, state: EgoState) -> None:
        if node_id not in self._tombstones:
            self.ego_states[node_id] = state

    def _on_gone(self, node_id: str, reason: str, t: float) -> None:
        self._tombstones[node_id] = t
        self.present.discard(node_id)
        self._remove(node_id, reason, t)

    def _on_present(self, node_id: str) -> None:
        self._tombstones.pop(node_id, None)
        self.present.add(node_id)

    def _remove(self, node_id: str, reason: str, t: float) -> None:
        if self.egos.pop(node_id, None) is not None:
            self.despawns.append(Despawn(node_id, reason, t))
            log.info("despawned %s (%s)", node_id, reason)
        self.ego_states.pop(node_id, None)

    # ------------------------------------------------------------ queries

    def ego_views(self, now: float) -> Iterator[ActorView]:
        for actor in self.egos.values():
            view = actor.view(now)
            if view is not None:
                yield view

    def npc_views(self, now: float) -> Iterator[ActorView]:
        for actor in self.npcs.values():
            view = actor.view(now)
            if view is not None:
                yield view


def _npc_pose(batch: NpcBatch, row: np.void) -> Pose:
    return Pose(
        batch.seq, batch.t, float(row["x"]), float(row["y"]), float(row["z"]),
        0.0, 0.0, float(row["yaw"]), float(row["vx"]), float(row["vy"]), 0.0,
        0.0, 0.0, float(row["yaw_rate"]),
    )  # fmt: skip
