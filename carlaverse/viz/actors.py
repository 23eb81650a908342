"""The actors of a view in Rerun: every ego and NPC where the world view (`world`) draws it.

The view decides one render time per frame (`WorldView.render_time`: now in `present` mode,
now minus the largest stream delay in `past` mode), so every actor of a frame is logged at
that one `sim_time` and their relative positions are true. Entities:

    world/egos/<node_id>     Boxes3D, labelled, coloured by kind (brighter than NPCs)
    world/npcs/<npc_id>      Boxes3D
    world/trails/<node_id>   LineStrips3D: where the ego was drawn
    world/trails/npcs        LineStrips3D: the NPCs' recent drawn paths, one entity for all

An actor whose drawn pose did not change (held, or a frame that came too soon) is not logged
again; rerun keeps it (latest-at). Style (kind, extent) is logged once and on change.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping

import numpy as np
import rerun as rr

from carlaverse import messages as m
from carlaverse.viz.model import ActorLook
from carlaverse.world.npc_table import NpcFrame
from carlaverse.world.remote_actor import ActorView
from carlaverse.world.world_view import WorldView

TRAIL_EGO = 600  # points kept per ego trail (30 s at 20 Hz)
TRAIL_NPC = 40  # points kept per NPC trail (2 s at 20 Hz)
EGO_COLOR_BOOST = 1.25  # egos are drawn brighter than NPCs of the same kind
KIND_COLORS: dict[str, tuple[int, int, int]] = {
    "car": (66, 135, 245),
    "van": (120, 100, 230),
    "truck": (150, 90, 40),
    "bus": (230, 170, 30),
    "motorcycle": (220, 60, 160),
    "bicycle": (40, 190, 90),
    "pedestrian": (250, 120, 40),
    "other": (150, 150, 150),
}

_Style = tuple[str, m.Extent]


def quaternion(roll: float, pitch: float, yaw: float) -> rr.Quaternion:
    """Body-to-world rotation for intrinsic Z-Y-X (yaw, pitch, roll) angles [rad]."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return rr.Quaternion(
        xyzw=[
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )


def kind_color(kind: str, ego: bool) -> tuple[int, int, int]:
    base = KIND_COLORS.get(kind, KIND_COLORS["other"])
    if not ego:
        return base
    return tuple(min(255, round(c * EGO_COLOR_BOOST)) for c in base)  # type: ignore[return-value]


class ActorLayer:
    """Logs a WorldView's actors at its render time into one recording stream."""

    def __init__(self, rec: rr.RecordingStream, trails: bool = True) -> None:
        self.rec = rec
        self.trails = trails
        self._styles: dict[str, _Style] = {}  # entity -> what its box last showed
        self._shown: dict[str, tuple[float, ...]] = {}  # ego -> the pose last logged
        self._ego_trails: dict[str, deque[tuple[float, float, float]]] = {}
        self._npc_trails: dict[str, deque[tuple[float, float, float]]] = {}
        self._npc_last: tuple[list[str], np.ndarray] | None = None  # ids, (x, y, z, yaw) rows

    def draw(self, view: WorldView, now: float, looks: Mapping[str, ActorLook]) -> float:
        """Log every actor as the view shows it at `now`; returns the render time [s]."""
        render_t = view.render_time(now)
        self.rec.set_time("sim_time", duration=render_t)
        self._depart(view, render_t)
        for actor in view.ego_views(now):
            self._ego(actor, looks.get(actor.actor_id, ActorLook()))
        self._npcs(view.npc_frame(now))
        return render_t

    # ------------------------------------------------------------------ egos

    def _ego(self, a: ActorView, look: ActorLook) -> None:
        shown = (a.x, a.y, a.z, a.roll, a.pitch, a.yaw)
        path = f"world/egos/{a.actor_id}"
        style = (look.kind, look.extent)
        if self._shown.get(a.actor_id) == shown and self._styles.get(path) == style:
            return  # held where it was: rerun keeps it
        self._shown[a.actor_id] = shown
        self._box(path, a.actor_id, (a.x, a.y, a.z), (a.roll, a.pitch, a.yaw), look, ego=True)
        trail = self._ego_trails.setdefault(a.actor_id, deque(maxlen=TRAIL_EGO))
        trail.append((a.x, a.y, a.z))
        if self.trails and len(trail) > 1:
            color = kind_color(look.kind, ego=True)
            strip = rr.LineStrips3D([list(trail)], colors=[color], radii=[0.08])
            self.rec.log(f"world/trails/{a.actor_id}", strip)

    def _box(
        self, path: str, label: str, xyz: tuple[float, float, float],
        rpy: tuple[float, float, float], look: ActorLook, ego: bool,
    ) -> None:  # fmt: skip
        e = look.extent
        center, rotation = [(xyz[0], xyz[1], xyz[2] + e.height / 2)], [quaternion(*rpy)]
        style = (look.kind, e)
        if self._styles.get(path) == style:
            # the hot path: rerun keeps the rest (latest-at), so only move the box
            self.rec.log(path, rr.Boxes3D.from_fields(centers=center, quaternions=rotation))
            return
        self._styles[path] = style
        box = rr.Boxes3D(
            centers=center,
            half_sizes=[(e.length / 2, e.width / 2, e.height / 2)],
            quaternions=rotation,
            labels=[label],
            colors=[kind_color(look.kind, ego)],
            fill_mode="solid" if ego else None,
        )
        self.rec.log(path, box)

    def _depart(self, view: WorldView, render_t: float) -> None:
        """Egos the view removed since the last frame: an event each, and their boxes go."""
        for gone in view.despawns:
            self.rec.set_time("sim_time", duration=gone.t)
            self.rec.log("events", rr.TextLog(f"{gone.actor_id} {gone.reason}", level="INFO"))
            self.rec.set_time("sim_time", duration=render_t)
            self._clear(f"world/egos/{gone.actor_id}")
            self._clear(f"world/trails/{gone.actor_id}")
            self._shown.pop(gone.actor_id, None)
            self._ego_trails.pop(gone.actor_id, None)
        view.despawns.clear()

    def _clear(self, path: str) -> None:
        self.rec.log(path, rr.Clear(recursive=True))
        self._styles.pop(path, None)

    # ------------------------------------------------------------------ NPCs

    def _npcs(self, frame: NpcFrame | None) -> None:
        if frame is None:
            if self._npc_last is not None:  # the NPC stream expired: nobody left to draw
                for npc_id in self._npc_last[0]:
                    self._clear(f"world/npcs/{npc_id}")
                self._npc_last, self._npc_trails = None, {}
            return
        pose = np.column_stack((frame.x, frame.y, frame.z, frame.yaw))
        moved = self._moved(frame.ids, pose)
        self._npc_last = (frame.ids, pose)
        if not moved.any():
            return
        kinds, rows = frame.kinds().tolist(), frame.rows
        extents = np.column_stack((rows["length"], rows["width"], rows["height"])).tolist()
        for i in np.flatnonzero(moved).tolist():
            x, y, z, yaw = pose[i].tolist()
            look = ActorLook(kinds[i], m.Extent(*extents[i]))
            npc_id = frame.ids[i]
            self._box(f"world/npcs/{npc_id}", npc_id, (x, y, z), (0.0, 0.0, yaw), look, ego=False)
            self._npc_trails.setdefault(npc_id, deque(maxlen=TRAIL_NPC)).append((x, y, z))
        if self.trails:
            self._log_npc_trails(frame.ids, kinds)

    def _moved(self, ids: list[str], pose: np.ndarray) -> np.ndarray:
        """Which NPCs to log: those drawn elsewhere than last frame; newcomers; after a change
        of membership everyone (and the departed are cleared)."""
        last = self._npc_last
        if last is not None and last[0] == ids:
            return (pose != last[1]).any(axis=1)
        if last is not None:
            for gone in set(last[0]) - set(ids):
                self._clear(f"world/npcs/{gone}")
                self._npc_trails.pop(gone, None)
        return np.ones(len(ids), dtype=bool)

    def _log_npc_trails(self, ids: list[str], kinds: list[str]) -> None:
        """All NPC trails as one entity: one call per frame instead of one per NPC."""
        strips, colors = [], []
        for npc_id, kind in zip(ids, kinds, strict=True):
            trail = self._npc_trails.get(npc_id)
            if trail is not None and len(trail) > 1:
                strips.append(list(trail))
                colors.append(kind_color(kind, ego=False))
        self.rec.log("world/trails/npcs", rr.LineStrips3D(strips, colors=colors, radii=[0.05]))
