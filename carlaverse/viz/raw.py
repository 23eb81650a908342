"""Actor samples on their way into a viewer's world view, and `--raw`: those samples drawn.

`ActorFeed` is the one way pose and NPC samples enter a viewer, from Zenoh callbacks (live)
or the playback loop: it validates, pushes into the `WorldView` inbox and, with `--raw`,
into a `RawTap` — O(1) appends, never a wait. The render thread logs the tap's samples at
their own session times, beside the view's interpolated actors, for diagnosis:

    world/raw/egos/<node_id>   Points3D: every pose sample as received, at pose.t
    world/raw/npcs             Points3D: every NPC of each batch as received, at batch.t
"""

from __future__ import annotations

from collections import Counter, deque

import numpy as np
import rerun as rr

from carlaverse import messages as m
from carlaverse.fabric.world_view import INBOX_LIMIT, WorldView

RAW_COLOR = (255, 0, 255)  # magenta: not a kind colour, so a raw sample never passes for an actor
RAW_RADIUS_M = 0.25  # [m]


class RawTap:
    """The samples a view was fed, until the render thread logs them."""

    def __init__(self) -> None:
        self.poses: deque[tuple[str, m.Pose]] = deque(maxlen=INBOX_LIMIT)
        self.npcs: deque[m.NpcBatch] = deque(maxlen=INBOX_LIMIT)

    def log(self, rec: rr.RecordingStream) -> None:
        """Log (and forget) everything tapped so far, each sample at its own session time."""
        while self.poses:
            node_id, pose = self.poses.popleft()
            rec.set_time("sim_time", duration=pose.t)
            rec.log(f"world/raw/egos/{node_id}", _points([(pose.x, pose.y, pose.z)]))
        while self.npcs:
            batch = self.npcs.popleft()
            rows = batch.array()
            rec.set_time("sim_time", duration=batch.t)
            rec.log("world/raw/npcs", _points(np.column_stack((rows["x"], rows["y"], rows["z"]))))


def _points(xyz: object) -> rr.Points3D:
    return rr.Points3D(xyz, colors=[RAW_COLOR], radii=[RAW_RADIUS_M])


class ActorFeed:
    """Pose and NPC samples into a world view (and a raw tap). Safe from any thread."""

    def __init__(self, view: WorldView, raw: RawTap | None = None) -> None:
        self.view = view
        self.raw = raw
        self.bad: Counter[str] = Counter()  # malformed samples dropped, by channel

    def pose(self, node_id: str, pose: m.Pose, rx_t: float) -> None:
        """A pose of `node_id` received at session time `rx_t` [s]."""
        self.view.push_pose(node_id, pose, rx_t)
        if self.raw is not None:
            self.raw.poses.append((node_id, pose))

    def npc(self, batch: m.NpcBatch, rx_t: float) -> None:
        if len(batch.rows) != len(batch.ids) * m.NPC_DTYPE.itemsize:
            self.bad["npc"] += 1  # rows and ids disagree: nothing in it can be placed
            return
        self.view.push_npc(batch, rx_t)
        if self.raw is not None:
            self.raw.npcs.append(batch)

    def decoded(self, channel: str, payload: bytes, node_id: str, rx_t: float) -> None:
        """A raw payload on `channel` ("pose" or "npc"): decode, count if bad, feed."""
        try:
            if channel == "pose":
                self.pose(node_id, m.POSE.decode(payload), rx_t)
            else:
                self.npc(m.NPC_BATCH.decode(payload), rx_t)
        except m.MessageError:
            self.bad[channel] += 1
