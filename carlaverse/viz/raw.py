"""Actor samples on their way into a viewer's world view, and `--raw`: those samples drawn.

`ActorFeed` is the one way pose and NPC samples enter a viewer, from Zenoh callbacks (live)
or the playback loop: it hands each to the world view's intake through a `SampleFeed` (the
view checks and decodes a pose's bytes in its update) and, with `--raw`, to a `RawTap` —
O(1) appends, never a wait. The render thread logs the tap's samples at their own session
times, beside the view's interpolated actors, for diagnosis:

    world/raw/egos/<node_id>   Points3D: every pose sample as received, at pose.t
    world/raw/npcs             Points3D: every NPC of each batch as received, at batch.t
"""

from __future__ import annotations

from collections import deque

import numpy as np
import rerun as rr

from carlaverse import messages as m
from carlaverse.keys import KeySpaceError, parse_cached
from carlaverse.world.intake import INBOX_LIMIT
from carlaverse.world.source import SampleFeed

RAW_COLOR = (255, 0, 255)  # magenta: not a kind colour, so a raw sample never passes for an actor
RAW_RADIUS_M = 0.25  # [m]


class RawTap:
    """The samples a view was fed, until the render thread logs them."""

    def __init__(self) -> None:
        self.poses: deque[tuple[str, bytes]] = deque(maxlen=INBOX_LIMIT)  # as received
        self.npcs: deque[m.NpcBatch] = deque(maxlen=INBOX_LIMIT)

    def log(self, rec: rr.RecordingStream) -> None:
        """Log (and forget) everything tapped so far, each sample at its own session time.
        A pose is decoded here, on the render thread, for the tap alone (one the view
        refused is not drawn: the view counted it)."""
        while self.poses:
            node_id, wire = self.poses.popleft()
            try:
                pose = m.decode_pose(wire)
            except m.MessageError:
                continue
            rec.set_time("sim_time", duration=pose.t)
            rec.log(f"world/raw/egos/{node_id}", _points([(pose.x, pose.y, pose.z)]))
        while self.npcs:
            batch = self.npcs.popleft()
            rows = batch.array()
            rec.set_time("sim_time", duration=batch.t)
            rec.log("world/raw/npcs", _points(np.column_stack((rows["x"], rows["y"], rows["z"]))))


def _points(xyz: np.ndarray | list[tuple[float, float, float]]) -> rr.Points3D:
    return rr.Points3D(xyz, colors=[RAW_COLOR], radii=[RAW_RADIUS_M])


class ActorFeed:
    """Pose and NPC samples into a world view (and a raw tap). Safe from any thread."""

    def __init__(self, samples: SampleFeed, raw: RawTap | None = None) -> None:
        self.samples = samples
        self.raw = raw

    def offer(self, key: str, payload: bytes, rx_t: float) -> None:
        """A pose or an NPC batch received on `key` at session time `rx_t` [s]; what does not
        decode (or a key outside the key space) is counted in the view's `dropped`."""
        try:
            parsed = parse_cached(key)
        except KeySpaceError:
            self.samples.intake.dropped.add("key")
            return
        message = self.samples.route_parsed(parsed, "put", payload, rx_t)
        if self.raw is None:
            return
        if isinstance(message, m.NpcBatch):
            self.raw.npcs.append(message)
        elif parsed.channel == "pose":
            self.raw.poses.append((parsed.node_id, payload))
