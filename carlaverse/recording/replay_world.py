"""The world a replay has played so far: what its authority's snapshot lists.

A live authority answers `authority/snapshot` with who is present now and where, so a node or
viewer that joins late starts with every actor in place. A replay must answer the same about
the recorded moment it is playing, not about the moment its recording was made (a recorded
snapshot's poses are as old as the recording's start, and a view refuses poses that far from
session time). So the replay hands every sample it sends here, and the snapshot is made from
the newest of each: each ego's pose and state, the whole-world NPC batch, lights, weather.

Who is present follows the recording: a presence token or spawn event adds a node, its token's
loss or a despawn event removes it, and a recorded snapshot adds those it lists. What each
node is (kind, actor kind, extent) comes from recorded snapshots and spawn events.

Payloads are kept as they travelled and decoded only when a snapshot is asked for (rarely,
against 50 poses a second per ego); one that does not decode is left out and counted.
"""

from __future__ import annotations

import threading

from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, ParsedKey
from carlaverse.support.tally import Tally

DEFAULT_MASS_KG = 1500.0  # [kg] the join request's default, for a node known only by its poses


class ReplayedWorld:
    """The newest replayed sample of each kind. Written by the replay thread, read by queries."""

    def __init__(self) -> None:
        self._lock = threading.Lock()  # held for a dict update or a copy: never while decoding
        self._poses: dict[str, bytes] = {}  # node id -> newest pose, 64 bytes
        self._states: dict[str, bytes] = {}  # node id -> newest EgoState payload
        self._world: dict[str, bytes] = {}  # npc | lights | weather -> newest payload
        self._infos: dict[str, m.EgoInfo] = {}  # what each node is, from the recording
        self.present: set[str] = set()  # read under the lock, or by the replay thread
        self.bad = Tally()  # payloads that did not decode, by channel

    def take(self, key: ParsedKey, kind: str, payload: bytes) -> None:
        """A sample the replay sent (or served, for `authority/snapshot`)."""
        if key.area == "node":
            self._presence(key.node_id, kind != "delete")
        elif kind != "put":
            return
        elif key.area == "ego" and key.channel in ("pose", "state"):
            with self._lock:
                (self._poses if key.channel == "pose" else self._states)[key.node_id] = payload
        elif key.area == "world" and key.channel in ("npc", "lights", "weather") and not key.tile:
            with self._lock:
                self._world[key.channel] = payload
        elif key.area == "world" and key.channel == "events":
            self._event(payload)
        elif (key.area, key.channel) == ("authority", "snapshot"):
            self._recorded_snapshot(payload)

    def clear(self) -> None:
        """Forget what was played: a new pass starts from the recording's beginning (what
        each node is stays known)."""
        with self._lock:
            for table in (self._poses, self._states, self._world):
                table.clear()
            self.present.clear()

    def is_present(self, node_id: str) -> bool:
        with self._lock:
            return node_id in self.present

    def actors(self) -> list[str]:
        """The present nodes, in order."""
        with self._lock:
            return sorted(self.present)

    # ------------------------------------------------------------ membership

    def _presence(self, node_id: str, alive: bool) -> None:
        if node_id == AUTHORITY_ID:
            return  # the recorded authority's token: the replay's authority stands in for it
        with self._lock:
            if alive:
                self.present.add(node_id)
            else:
                self.present.discard(node_id)

    def _event(self, payload: bytes) -> None:
        try:
            event = m.WORLD_EVENT.decode(payload)
        except m.MessageError:
            self.bad.add("events")
            return
        if isinstance(event, m.Spawned) and event.node_id != AUTHORITY_ID:
            info = m.EgoInfo(event.node_id, event.kind, event.actor_kind, m.Extent(),
                             DEFAULT_MASS_KG)  # fmt: skip
            with self._lock:
                self._infos.setdefault(event.node_id, info)
                self.present.add(event.node_id)
        elif isinstance(event, m.Despawned):
            self._presence(event.node_id, False)

    def know(self, payload: bytes) -> None:
        """What each node of a recorded snapshot is, whenever the recording has it: a node's
        kind and extent do not change, and a spawn event alone may not say (a replay
        read ahead for this before it plays). Who is present it does not change."""
        self._recorded_snapshot(payload, present=False)

    def _recorded_snapshot(self, payload: bytes, present: bool = True) -> None:
        try:
            snapshot = m.SNAPSHOT.decode(payload)
        except m.MessageError:
            self.bad.add("snapshot")
            return
        with self._lock:
            for ego in snapshot.egos:
                if ego.node_id != AUTHORITY_ID:
                    self._infos[ego.node_id] = _without_pose(ego)
                    if present:
                        self.present.add(ego.node_id)

    # ------------------------------------------------------------ the snapshot

    def snapshot(self, t: float) -> m.Snapshot:
        """Who is present and where, as replayed up to session time `t` [s]."""
        with self._lock:
            present = sorted(self.present)
            poses, states = dict(self._poses), dict(self._states)
            infos, world = dict(self._infos), dict(self._world)
        egos = [self._ego(n, infos.get(n), poses.get(n), states.get(n)) for n in present]
        npc = self._decoded(world.get("npc"), m.NPC_BATCH, "npc")
        lights = self._decoded(world.get("lights"), m.LIGHTS, "lights")
        weather = self._decoded(world.get("weather"), m.WEATHER, "weather")
        return m.Snapshot(m.SCHEMA_VERSION, t, egos, npc, lights, weather)  # type: ignore[arg-type]

    def _ego(
        self, node_id: str, info: m.EgoInfo | None, pose: bytes | None, state: bytes | None
    ) -> m.EgoInfo:
        pose = pose if pose is not None and self._pose_ok(pose) else None
        if info is None:  # known by its token or poses alone: an actor if it moved
            info = m.EgoInfo(node_id, "replayed", "car" if pose else "", m.Extent(),
                             DEFAULT_MASS_KG)  # fmt: skip
        decoded = self._decoded(state, m.EGO_STATE, "state")
        return m.EgoInfo(info.node_id, info.kind, info.actor_kind, info.extent, info.mass_kg,
                         info.site, pose, decoded)  # type: ignore[arg-type]  # fmt: skip

    def _pose_ok(self, wire: bytes) -> bool:
        try:
            m.decode_pose(wire)
        except m.MessageError:
            self.bad.add("pose")
            return False
        return True

    def _decoded(self, payload: bytes | None, codec: m.Codec, channel: str) -> object | None:
        if payload is None:
            return None
        try:
            return codec.decode(payload)
        except m.MessageError:
            self.bad.add(channel)
            return None


def _without_pose(ego: m.EgoInfo) -> m.EgoInfo:
    """A recorded snapshot's entry, for what the node is: its pose there is as old as that
    snapshot, and the replayed poses say where it is now."""
    return m.EgoInfo(ego.node_id, ego.kind, ego.actor_kind, ego.extent, ego.mass_kg, ego.site)
