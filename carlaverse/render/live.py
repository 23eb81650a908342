"""The render process's own picture of a live session: everyone else over the fabric, the
node itself from shared memory, the newest skeleton per walker.

Everyone else comes through an observer `NodeClient` of the render process's own (id
`<node id>.view`, kind `observer`: the authority gives it no body). It brings what every node
has: the session clock, the snapshot for late joiners, presence, validation of every sample,
and, asked for, every walker's skeleton, of which the world view keeps the newest valid one
per present node; frames get them as joint-angle maps. The node's own actor is read from its
shared-memory state block (`shm_layouts.OwnPoseBlock`) each frame, so the driver's view of
their own car has no network delay; the client's world view leaves that actor out
(`own_actor`), so the copy of its pose that comes back over the fabric is never decoded.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import replace

import numpy as np
import zenoh

from carlaverse import messages as m
from carlaverse.fov import EyeFov
from carlaverse.render.frame import (
    ActorDraw,
    Dashboard,
    SceneFrame,
    blink_on,
    frame_from_view,
    skeleton_angles,
    with_skeletons,
)
from carlaverse.shm import SharedBlock, TornRead
from carlaverse.shm_layouts import EDGES, EYES, OWN_POSE_FIELDS, OwnPoseBlock
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import JoinRefused, NodeClient, NodeSettings

log = logging.getLogger(__name__)

VIEW_SUFFIX = ".view"  # the render process joins as `<node id>.view`
MAP_QUERY_S = 5.0  # [s] the map is large: give its query time
ARRIVAL_POLL_S = 0.05  # [s] between looks for the first actors


class WorldMissing(Exception):
    """Part of a live session did not arrive in time; the message names which part."""


class OwnPose:
    """Reads the node's own pose from its block; attaches once the node has created it.

    A block with `written_ns` (the host's monotonic clock when the loop wrote the record)
    lets a view measure motion-to-photon from there (`render.process`)."""

    def __init__(self, spec: OwnPoseBlock, actor_id: str) -> None:
        missing = [f for f in OWN_POSE_FIELDS if f not in (spec.dtype.names or ())]
        if missing:
            raise ValueError(f"own-pose block {spec.name}: dtype lacks fields {missing}")
        self.spec = spec
        self.actor_id = actor_id
        self._block: SharedBlock | None = None
        self.torn_reads = 0
        self.eyes: tuple[EyeFov, EyeFov] | None = None  # a headset's, from the last read
        self.dash: Dashboard | None = None  # the instruments, from the last read
        self.written_ns = 0  # the drawn record's `written_ns`; 0: the block has no stamp

    def actor(self) -> ActorDraw | None:
        """The node's actor now, or None before its loop runs."""
        record = self._read()
        if record is None:
            return None
        names = self.spec.dtype.names or ()
        if "running" in names and not record["running"]:
            return None
        self.eyes = _eye_fovs(record) if "eyes" in names else None
        self.written_ns = int(record["written_ns"]) if "written_ns" in names else 0
        size = self.spec.extent
        lights = int(record["lights"]) if "lights" in names else 0
        pitch, roll = (float(record[f]) if f in names else 0.0 for f in ("pitch", "roll"))
        speed, yaw_rate, steer = (float(record[f]) if f in names else None
                                  for f in ("speed_mps", "yaw_rate", "steer_rad"))  # fmt: skip
        self.dash = _dashboard(record, names, lights) if speed is not None else None
        return ActorDraw(
            self.actor_id, self.spec.kind, float(record["x"]), float(record["y"]), 0.0,
            float(record["yaw"]), size.length, size.width, size.height, pitch, roll,
            lights=lights, ego=True, speed=speed, yaw_rate=yaw_rate, steer=steer,
        )  # fmt: skip

    def _read(self) -> np.void | None:
        if self._block is None:
            try:
                self._block = SharedBlock(self.spec.name, self.spec.dtype)
            except FileNotFoundError:
                return None  # the node creates it when its loop starts
        try:
            return self._block.read()
        except TornRead:
            self.torn_reads += 1
            return None

    def close(self) -> None:
        if self._block is not None:
            self._block.close()
            self._block = None


def _dashboard(record: np.void, names: tuple[str, ...], lights: int) -> Dashboard:
    """The HUD's instruments: indicator arrows lit in the loop's flasher phase (`blink_on`),
    else in the render time's."""
    flash = bool(record["blink_on"]) if "blink_on" in names else blink_on(float(record["t"]))
    gear = int(record["gear"]) if "gear" in names else None
    return Dashboard(float(record["speed_mps"]), gear,
                     flash and bool(lights & m.LIGHT_LEFT_BLINKER),
                     flash and bool(lights & m.LIGHT_RIGHT_BLINKER))  # fmt: skip


def _eye_fovs(record: np.void) -> tuple[EyeFov, EyeFov] | None:
    if not record["eyes"]:
        return None
    left, right = (EyeFov(*(float(record[f"{eye}_{e}"]) for e in EDGES)) for eye in EYES)
    return left, right


class LiveWorld:
    """Everything the render process draws of a live session, at one session time."""

    def __init__(
        self, session: zenoh.Session, node: NodeSettings, own: OwnPoseBlock | None
    ) -> None:
        settings = NodeSettings(
            node_id=f"{node.node_id}{VIEW_SUFFIX}", session=node.session, kind="observer",
            actor_kind="", site=node.site, interpolation=node.interpolation,
        )  # fmt: skip
        self.node_id = node.node_id
        self.client = NodeClient(
            session, settings, MonotonicClock(), own_actor=node.node_id, skeletons=True
        )
        self.own = OwnPose(own, node.node_id) if own is not None else None

    def start(self) -> LiveWorld:
        self.client.start()
        return self

    def wait_for_map(self, deadline: float, stop: threading.Event) -> m.MapReply | None:
        """The session's map once the authority has admitted this view (it may start after
        us); None when the session has no map (`--scenario none`). Raises WorldMissing
        naming what did not come before the monotonic `deadline` (or when `stop` is set)."""
        try:
            while not self.client.wait_joined(0.2):
                if stop.is_set() or time.monotonic() > deadline:
                    raise WorldMissing(self._not_admitted())
        except JoinRefused as exc:
            raise WorldMissing(f"the authority refused {self.client.node_id!r}: {exc}") from exc
        answered, road_map = self._query_map(MAP_QUERY_S)
        if not answered:
            raise WorldMissing(f"the authority did not answer for its map in {MAP_QUERY_S:g} s")
        return road_map

    def wait_for_actors(
        self, deadline: float, stop: threading.Event, actor_id: str | None = None
    ) -> SceneFrame:
        """The first frame with actor `actor_id` in it, or (None) after an NPC batch or
        another node's pose has arrived. Raises WorldMissing when that does not happen
        before the monotonic `deadline` (or when `stop` is set)."""
        while True:
            frame = self.frame()
            if self._arrived(frame, actor_id):
                return frame
            if stop.wait(ARRIVAL_POLL_S) or time.monotonic() > deadline:
                raise WorldMissing(self._not_arrived(frame, actor_id))

    def _arrived(self, frame: SceneFrame, actor_id: str | None) -> bool:
        if actor_id is not None:
            return frame.actor(actor_id) is not None
        world = self.client.world
        return bool(world.egos) or world.npc_frame(frame.t) is not None

    def _not_arrived(self, frame: SceneFrame, actor_id: str | None) -> str:
        session = self.client.settings.session
        if actor_id is None:
            return f"no NPC batch and no node's pose arrived: session {session!r} is empty"
        egos = ", ".join(sorted(a.actor_id for a in frame.actors if a.ego)) or "none"
        return f"node {actor_id!r} is not in session {session!r} (nodes there: {egos})"

    def _not_admitted(self) -> str:
        return f"no authority of session {self.client.settings.session!r} admitted this view"

    def _query_map(self, timeout_s: float) -> tuple[bool, m.MapReply | None]:
        """(whether the authority answered, its map): an error reply means it has none."""
        key = self.client.keys.authority("map")
        try:
            for reply in self.client.session.get(key, timeout=timeout_s):
                if reply.ok is None:
                    return True, None
                return True, m.MAP.decode(reply.ok.payload.to_bytes())
        except zenoh.ZError as exc:
            log.warning("map query failed: %s", exc)
        except m.MessageError as exc:
            log.warning("the authority's map does not decode: %s", exc)
        return False, None

    def frame(self) -> SceneFrame:
        now = self.client.update()
        world = self.client.world
        kinds, extents = _snapshot_attributes(self.client.snapshot)
        frame = frame_from_view(world, now, kinds=kinds, extents=extents)
        frame = with_skeletons(frame, skeleton_angles(world))
        own = self.own.actor() if self.own is not None else None
        return frame if own is None else replace(frame, actors=(*frame.actors, own))

    def close(self) -> None:
        self.client.close()
        if self.own is not None:
            self.own.close()


def _snapshot_attributes(
    snapshot: m.Snapshot | None,
) -> tuple[dict[str, str], dict[str, m.Extent]]:
    if snapshot is None:
        return {}, {}
    kinds = {e.node_id: e.actor_kind for e in snapshot.egos if e.actor_kind}
    return kinds, {e.node_id: e.extent for e in snapshot.egos}
