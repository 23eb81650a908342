"""The session's world as ROS 2 messages (plain dicts for `cdr.encode`), one function each.

Every actor -- ego or NPC -- is an `ActorState` in the world frame (`frames`: ENU, so REP 103's
`map` as it stands). What each topic carries is in docs/protocol.md ("ROS 2 over Zenoh").
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from carlaverse import messages as m
from carlaverse.ros2 import frames
from carlaverse.ros2 import types as t
from carlaverse.ros2.keys import ros_token
from carlaverse.world.npc_table import NpcFrame
from carlaverse.world.remote_actor import ActorView

# RGBA per actor kind in the marker array: egos stand out from NPCs.
EGO_COLOR = {"r": 0.95, "g": 0.45, "b": 0.05, "a": 0.9}
NPC_COLOR = {"r": 0.2, "g": 0.5, "b": 0.95, "a": 0.8}
# What an AV's odometry may say: the pose layout keeps millimetres to ~16 km as float32, and
# its rates are float16 (to 65504); a road vehicle is far within both.
POSITION_LIMIT_M = 1e6  # [m]
RATE_LIMIT = 1e3  # [m/s] and [rad/s]


@dataclass(frozen=True, slots=True)
class ActorState:
    """One actor at one session time, world frame (x east, y north, z up) [m, rad, m/s]."""

    actor_id: str
    kind: str  # one of messages.ACTOR_KINDS, or "" when not known
    ego: bool
    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float
    vx: float
    vy: float
    vz: float
    yaw_rate: float  # [rad/s] counter-clockwise seen from above
    extent: m.Extent

    @property
    def frame(self) -> str:
        """Its TF frame: `<id as a ROS token>/base_link` (REP 105's name, one per actor)."""
        return f"{ros_token(self.actor_id)}/base_link"


def ego_state(
    view: ActorView, kind: str, yaw_rate: float, extent: m.Extent | None = None
) -> ActorState:
    """An ego as drawn; without its own extent, the typical one of its kind."""
    extent = extent or m.KIND_EXTENTS.get(kind or "car", m.KIND_EXTENTS["other"])
    return ActorState(view.actor_id, kind, True, view.x, view.y, view.z, view.roll,
                      view.pitch, view.yaw, view.vx, view.vy, view.vz, yaw_rate,
                      extent)  # fmt: skip


def npc_states(frame: NpcFrame) -> Iterator[ActorState]:
    rows, kinds = frame.rows, frame.kinds()
    values = zip(frame.ids, frame.x.tolist(), frame.y.tolist(), frame.z.tolist(),
                 frame.yaw.tolist(), frame.vx.tolist(), frame.vy.tolist(),
                 rows["yaw_rate"].tolist(), rows["length"].tolist(), rows["width"].tolist(),
                 rows["height"].tolist(), kinds.tolist(), strict=True)  # fmt: skip
    for npc_id, x, y, z, yaw, vx, vy, rate, length, width, height, kind in values:
        yield ActorState(npc_id, str(kind), False, x, y, z, 0.0, 0.0, yaw, vx, vy, 0.0,
                         rate, m.Extent(length, width, height))  # fmt: skip


def header(time_s: float, frame_id: str) -> dict[str, Any]:
    return {"stamp": frames.stamp(time_s), "frame_id": frame_id}


def _pose(a: ActorState, dz: float = 0.0) -> dict[str, Any]:
    qx, qy, qz, qw = frames.quaternion_from_rpy(a.roll, a.pitch, a.yaw)
    return {
        "position": {"x": a.x, "y": a.y, "z": a.z + dz},
        "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
    }


def clock(time_s: float) -> dict[str, Any]:
    return {"clock": frames.stamp(time_s)}


def tf(actors: Iterable[ActorState], time_s: float, map_frame: str) -> dict[str, Any]:
    """map -> `<actor>/base_link`, one transform per actor."""
    transforms = []
    for a in actors:
        pose = _pose(a)
        transforms.append({
            "header": header(time_s, map_frame), "child_frame_id": a.frame,
            "transform": {"translation": pose["position"], "rotation": pose["orientation"]},
        })  # fmt: skip
    return {"transforms": transforms}


def odometry(a: ActorState, time_s: float, map_frame: str) -> dict[str, Any]:
    """nav_msgs/Odometry: the pose in `map_frame`, the twist in the actor's own frame."""
    r = frames.rotation(a.roll, a.pitch, a.yaw)
    linear = frames.to_body(r, (a.vx, a.vy, a.vz))
    # Only the yaw rate is known (about the world's z); in the body frame it tilts with the body.
    angular = frames.to_body(r, (0.0, 0.0, a.yaw_rate))
    return {
        "header": header(time_s, map_frame),
        "child_frame_id": a.frame,
        "pose": {"pose": _pose(a)},
        "twist": {"twist": {
            "linear": dict(zip("xyz", linear, strict=True)),
            "angular": dict(zip("xyz", angular, strict=True)),
        }},
    }  # fmt: skip


def marker_array(
    actors: Iterable[ActorState],
    ids: dict[str, int],
    time_s: float,
    map_frame: str,
    lifetime_s: float,
) -> dict[str, Any]:
    """A CUBE per actor, its box centred half its height above its pose; `ids` keeps each
    actor's marker id stable for the bridge's run. Markers outlive a frame by `lifetime_s`,
    so an actor that is gone is gone from RViz without a DELETE."""
    life = frames.stamp(lifetime_s)
    markers = []
    for a in actors:
        e = a.extent
        markers.append({
            "header": header(time_s, map_frame), "ns": "egos" if a.ego else "npcs",
            "id": ids.setdefault(a.actor_id, len(ids) + 1), "type": t.MARKER_CUBE,
            "action": t.MARKER_ADD, "pose": _pose(a, e.height / 2),
            "scale": {"x": e.length, "y": e.width, "z": e.height},
            "color": EGO_COLOR if a.ego else NPC_COLOR, "lifetime": life, "text": a.actor_id,
        })  # fmt: skip
    return {"markers": markers}


def detections(actors: Iterable[ActorState], time_s: float, map_frame: str) -> dict[str, Any]:
    """vision_msgs/Detection3DArray: one detection per actor, ground truth (score 1), its
    class the actor kind, its box centred half its height above its pose."""
    out = []
    for a in actors:
        e = a.extent
        centre = _pose(a, e.height / 2)
        out.append({
            "header": header(time_s, map_frame),
            "results": [{"hypothesis": {"class_id": a.kind or "other", "score": 1.0},
                         "pose": {"pose": _pose(a)}}],
            "bbox": {"center": centre, "size": {"x": e.length, "y": e.width, "z": e.height}},
            "id": a.actor_id,
        })  # fmt: skip
    return {"header": header(time_s, map_frame), "detections": out}


def traffic_lights(lights: m.LightsState, map_frame: str) -> dict[str, Any]:
    return {
        "header": header(lights.t, map_frame),
        "lights": [
            {"id": light.id, "state": light.state, "phase": light.phase,
             "remaining_s": light.remaining_s}
            for light in lights.lights
        ],
    }  # fmt: skip


def collision(impulse: m.Impulse, map_frame: str) -> dict[str, Any]:
    """carlaverse_msgs/CollisionImpulse: the authority's impulse on this ego [N·s], world
    frame, stamped with the session time it applies at."""
    return {
        "header": header(impulse.t, map_frame),
        "contact_id": impulse.contact_id,
        "impulse": dict(zip("xyz", impulse.impulse, strict=True)),
        "point": dict(zip("xyz", impulse.point, strict=True)),
        "normal": dict(zip("xyz", impulse.normal, strict=True)),
        "other_id": impulse.other_id,
        "other_kind": impulse.other_kind,
        "relative_speed_mps": impulse.relative_speed_mps,
    }


def pose_from_odometry(message: dict[str, Any], time_s: float) -> m.Pose:
    """A session pose from nav_msgs/Odometry (pose in the map frame, twist in the child
    frame), valid at session time `time_s`; ValueError when a value is not finite."""
    p = message["pose"]["pose"]
    q = p["orientation"]
    roll, pitch, yaw = frames.rpy_from_quaternion((q["x"], q["y"], q["z"], q["w"]))
    twist = message["twist"]["twist"]
    r = frames.rotation(roll, pitch, yaw)
    lin, ang = twist["linear"], twist["angular"]
    vx, vy, vz = frames.to_world(r, (lin["x"], lin["y"], lin["z"]))
    wx, wy, wz = frames.to_world(r, (ang["x"], ang["y"], ang["z"]))
    pos = p["position"]
    position = (pos["x"], pos["y"], pos["z"])
    rates = (vx, vy, vz, wx, wy, wz)
    if not all(math.isfinite(v) for v in (*position, *rates)):
        raise ValueError("odometry holds a value that is not finite")
    if max(map(abs, position)) > POSITION_LIMIT_M or max(map(abs, rates)) > RATE_LIMIT:
        raise ValueError("odometry is out of range for a road vehicle")
    return m.Pose(0, time_s, *position, roll, pitch, yaw, *rates)
