"""A world view fed from an MCAP recording, so any moment of a session can be rendered.

Samples go into a real `WorldView` exactly as a live node's callbacks would put them, in
receive order; the receive time is the recorder's log time moved onto the session clock
(by the offset of the first pose: log time − the pose's own session time). `advance(t)`
feeds everything received up to session time `t`; the view then decides what it shows at
`t`, as it would have live (walkers' skeletons included). Extents and NPC lamps,
which the view does not keep, come from the recorded snapshot and NPC batches.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.fabric.remote_actor import InterpolationSettings
from carlaverse.fabric.world_view import WorldView
from carlaverse.recording.reading import RecordedSample, iter_samples
from carlaverse.render.frame import SceneFrame, frame_from_view, npc_attributes, with_skeletons
from carlaverse.render.live import skeleton_angles

log = logging.getLogger(__name__)
VIEW_ID = "carlaverse-render"  # never a node id of the session: ids are reserved per node


def first_pose(path: str | Path) -> RecordedSample | None:
    for sample in iter_samples(path):
        if sample.kind == "put" and _is_pose(sample.key):
            return sample
    return None


def _is_pose(key: str) -> bool:
    try:
        return keyspace.parse(key).channel == "pose"
    except keyspace.KeySpaceError:
        return False


def first_pose_time(path: str | Path) -> float:
    """Session time [s] of the first recorded pose (0 when there is none)."""
    sample = first_pose(path)
    return sample.publish_time_ns / 1e9 if sample else 0.0


def receive_offset_ns(path: str | Path) -> int:
    """[ns] the recorder's log time minus session time, from the first pose (0 without one:
    the log time is all there is)."""
    pose = first_pose(path)
    return pose.log_time_ns - pose.publish_time_ns if pose else 0


def recording_start_time(path: str | Path) -> float:
    """Session time [s] at which the recording starts: when its first sample was received
    (a recorder usually starts before the nodes, so this is before the first pose)."""
    first = next(iter_samples(path), None)  # in ns until the end: 1e18 ns do not fit a float
    return (first.log_time_ns - receive_offset_ns(path)) / 1e9 if first else 0.0


class RecordedWorld:
    """Replays a recording into a WorldView, forward only."""

    def __init__(self, path: str | Path, settings: InterpolationSettings | None = None) -> None:
        self.view = WorldView(VIEW_ID, settings or InterpolationSettings())
        self.kinds: dict[str, str] = {}
        self.extents: dict[str, m.Extent] = {}
        self.npc_lights: dict[str, int] = {}
        self.bad_samples = 0
        self._samples: Iterator[RecordedSample] = iter_samples(path)
        self._next: RecordedSample | None = next(self._samples, None)
        self._offset_s = receive_offset_ns(path) / 1e9  # [s] log time minus session time

    def advance(self, t: float) -> None:
        """Feed every sample received up to session time `t` [s], then update the view."""
        while self._next is not None and self._session_rx(self._next) <= t:
            self._feed(self._next)
            self._next = next(self._samples, None)
        self.view.update(t)

    def frame(self, t: float) -> SceneFrame:
        self.advance(t)
        frame = frame_from_view(
            self.view, t, kinds=self.kinds, extents=self.extents, npc_lights=self.npc_lights
        )
        return with_skeletons(frame, skeleton_angles(self.view))

    def _session_rx(self, sample: RecordedSample) -> float:
        return sample.log_time_ns / 1e9 - self._offset_s

    def _feed(self, sample: RecordedSample) -> None:
        try:
            key = keyspace.parse(sample.key)
            self._dispatch(key, sample, self._session_rx(sample))
        except (keyspace.KeySpaceError, m.MessageError) as exc:
            self.bad_samples += 1
            log.debug("skipped %s: %s", sample.key, exc)

    def _dispatch(self, key: keyspace.ParsedKey, sample: RecordedSample, rx: float) -> None:
        view, payload = self.view, sample.payload
        if key.area == "node":
            gone = sample.kind == "delete"
            view.push_gone(key.node_id, "liveliness", rx) if gone else view.push_present(
                key.node_id
            )
        elif key.area == "ego" and key.channel == "pose":
            view.push_pose(key.node_id, m.POSE.decode(payload), rx)
        elif key.area == "ego" and key.channel == "skeleton":
            view.push_skeleton(key.node_id, m.SKELETON.decode(payload))
        elif key.area == "ego" and key.channel == "state":
            view.inbox.append(("state", key.node_id, m.EGO_STATE.decode(payload)))
        elif key.area == "world" and not key.tile:  # a tile's NPCs are in the whole batch too
            self._world(key.channel, payload, rx)
        elif key.area == "authority" and key.channel == "snapshot":
            self._snapshot(m.SNAPSHOT.decode(payload), rx)

    def _world(self, channel: str, payload: bytes, rx: float) -> None:
        if channel == "npc":
            batch = m.NPC_BATCH.decode(payload)
            extents, lamps = npc_attributes(batch)
            self.extents.update(extents)
            self.npc_lights = lamps
            self.view.push_npc(batch, rx)
        elif channel == "lights":
            self.view.lights = m.LIGHTS.decode(payload)
        elif channel == "weather":
            self.view.weather = m.WEATHER.decode(payload)
        elif channel == "events":
            event = m.WORLD_EVENT.decode(payload)
            if isinstance(event, m.Despawned):
                self.view.push_gone(event.node_id, event.reason, rx)
            elif isinstance(event, m.Spawned):
                self.view.push_present(event.node_id)

    def _snapshot(self, snapshot: m.Snapshot, rx: float) -> None:
        for ego in snapshot.egos:
            self.kinds[ego.node_id] = ego.actor_kind
            self.extents[ego.node_id] = ego.extent
        self.view.inbox.append(("snapshot", snapshot, rx))
