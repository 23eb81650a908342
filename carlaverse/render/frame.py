"""What one rendered frame shows, taken from the world view (`carlaverse.world`) at one time.

The renderer never reads raw samples: `frame_from_view` asks the `WorldView` for every ego and
NPC at `now` (the view decides the render time), adds each ego's lamps from its `EgoState`,
and hands the layers plain data. No Panda3D here, so this is testable without a GPU.

An actor's reference point is the centre of its footprint on the ground; its box spans
z .. z + height. Extents come from the caller (the map reply, a join reply, a recording's
NPC rows) and default to a typical size per kind.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from carlaverse.messages import (
    KIND_EXTENTS,
    LIGHT_LEFT_BLINKER,
    LIGHT_RIGHT_BLINKER,
    EgoState,
    Extent,
    LightsState,
    NpcBatch,
    Skeleton,
    Weather,
)
from carlaverse.world.world_view import WorldView

INDICATOR_BITS = {
    "off": 0,
    "left": LIGHT_LEFT_BLINKER,
    "right": LIGHT_RIGHT_BLINKER,
    "hazard": LIGHT_LEFT_BLINKER | LIGHT_RIGHT_BLINKER,
}


# Indicators flash at 1.5 Hz, half the period lit (UN ECE R48: 90 ± 30 flashes per minute),
# timed off the render time so that a frame is reproducible.
BLINK_HZ = 1.5  # [Hz]


def blink_on(t: float) -> bool:
    """Whether a flashing indicator is lit at render time `t` [s]."""
    return (t * BLINK_HZ) % 1.0 < 0.5


# (roll, pitch, yaw) [rad] per joint name, from a `Skeleton` (see `figure` for the convention)
JointAngles = Mapping[str, tuple[float, float, float]]


@dataclass(frozen=True, slots=True)
class ActorDraw:
    actor_id: str
    kind: str
    x: float  # [m] world frame, centre of the footprint
    y: float
    z: float
    yaw: float  # [rad] counter-clockwise from +x
    length: float  # [m]
    width: float
    height: float
    pitch: float = 0.0  # [rad] nose down positive (ISO 8855)
    roll: float = 0.0  # [rad] right side down positive
    lights: int = 0  # LIGHT_* bits
    ego: bool = False
    skeleton: JointAngles | None = None  # a walker's joint angles, when it sends them
    # What the pose alone does not say; None where the source does not send it (the actor
    # layer then takes it from the actor's own motion between frames, `motion.Motion`):
    speed: float | None = None  # [m/s] along the heading, negative in reverse
    yaw_rate: float | None = None  # [rad/s] counter-clockwise
    steer: float | None = None  # [rad] road-wheel (or fork) angle, left positive


@dataclass(frozen=True, slots=True)
class Dashboard:
    """What the own vehicle's instruments show, read from the node loop's shared state."""

    speed_mps: float  # [m/s]
    gear: int | None = None  # -1 reverse, 0 neutral, 1.. forward; None: no gearbox (a bike)
    left: bool = False  # the left indicator lamp is lit now
    right: bool = False


@dataclass(frozen=True, slots=True)
class SceneFrame:
    t: float  # [s] the session time the frame shows
    actors: tuple[ActorDraw, ...] = ()
    lights: LightsState | None = None
    weather: Weather | None = None

    def actor(self, actor_id: str) -> ActorDraw | None:
        return next((a for a in self.actors if a.actor_id == actor_id), None)


def ego_lamps(state: EgoState | None) -> int:
    """Light bits of an ego, with the indicator folded into the blinker bits."""
    if state is None:
        return 0
    return state.lights | INDICATOR_BITS.get(state.indicator, 0)


def extent_of(kind: str, extents: Mapping[str, Extent], actor_id: str) -> Extent:
    return extents.get(actor_id) or KIND_EXTENTS.get(kind) or KIND_EXTENTS["other"]


def frame_from_view(
    view: WorldView,
    now: float,
    *,
    kinds: Mapping[str, str] | None = None,
    extents: Mapping[str, Extent] | None = None,
    npc_lights: Mapping[str, int] | None = None,
) -> SceneFrame:
    """Everything `view` (a WorldView) shows at session time `now`.

    `kinds`, `extents` and `npc_lights` map actor ids to what the view itself does not keep;
    a kind missing there is taken from the view's actor record when it has one.
    """
    kinds, extents, npc_lights = kinds or {}, extents or {}, npc_lights or {}
    states: Mapping[str, EgoState] = view.ego_states
    actors = []
    for v in view.ego_views(now):
        kind = kinds.get(v.actor_id) or _view_kind(view, v.actor_id) or "car"
        size = extent_of(kind, extents, v.actor_id)
        actors.append(
            ActorDraw(
                v.actor_id, kind, v.x, v.y, v.z, v.yaw, size.length, size.width,
                size.height, v.pitch, v.roll, ego_lamps(states.get(v.actor_id)), True,
                speed=along(v.vx, v.vy, v.yaw),
            )
        )  # fmt: skip
    actors.extend(_npcs(view, now, extents, npc_lights))
    return SceneFrame(now, tuple(actors), view.lights, view.weather)


def _npcs(
    view: WorldView, now: float, extents: Mapping[str, Extent], npc_lights: Mapping[str, int]
) -> list[ActorDraw]:
    """NPCs from the view's array frame: kind, extent and lamps travel in its rows."""
    frame = view.npc_frame(now)
    if frame is None:
        return []
    rows, kinds = frame.rows, frame.kinds()
    out = []
    for i, npc_id in enumerate(frame.ids):
        kind = str(kinds[i])
        size = extents.get(npc_id)
        if size is None and rows["length"][i] > 0:
            size = Extent(
                float(rows["length"][i]), float(rows["width"][i]), float(rows["height"][i])
            )
        size = size or extent_of(kind, {}, npc_id)
        lamps = npc_lights.get(npc_id, int(rows["lights"][i]))
        yaw = float(frame.yaw[i])
        out.append(
            ActorDraw(
                npc_id, kind, float(frame.x[i]), float(frame.y[i]), float(frame.z[i]),
                yaw, size.length, size.width, size.height, lights=lamps,
                speed=along(float(frame.vx[i]), float(frame.vy[i]), yaw),
                yaw_rate=float(rows["yaw_rate"][i]),
            )
        )  # fmt: skip
    return out


def along(vx: float, vy: float, yaw: float) -> float:
    """[m/s] a world-frame velocity's part along the heading `yaw` (negative: reversing)."""
    return vx * math.cos(yaw) + vy * math.sin(yaw)


def with_skeletons(frame: SceneFrame, skeletons: Mapping[str, JointAngles]) -> SceneFrame:
    """The frame with each actor's joint angles attached where it sent a skeleton."""
    if not skeletons:
        return frame
    actors = tuple(
        replace(a, skeleton=skeletons[a.actor_id]) if a.actor_id in skeletons else a
        for a in frame.actors
    )
    return replace(frame, actors=actors)


def _view_kind(view: WorldView, actor_id: str) -> str:
    actor = view.egos.get(actor_id)
    return getattr(actor, "kind", "") if actor is not None else ""


def npc_attributes(batch: NpcBatch) -> tuple[dict[str, Extent], dict[str, int]]:
    """Extents and light bits per NPC id from a batch."""
    rows = batch.array()
    extents, lights = {}, {}
    for npc_id, row in zip(batch.ids, rows, strict=False):
        length, width, height = float(row["length"]), float(row["width"]), float(row["height"])
        if length > 0 and width > 0 and height > 0:
            extents[npc_id] = Extent(length, width, height)
        lights[npc_id] = int(row["lights"])
    return extents, lights


def skeleton_angles(view: WorldView) -> dict[str, JointAngles]:
    """Joint angles per walker the view keeps a skeleton of."""
    return {node_id: joint_angles(s) for node_id, s in view.skeletons.items()}


def joint_angles(skeleton: Skeleton) -> JointAngles:
    """(roll, pitch, yaw) [rad] per joint name, from the float32 triplets."""
    values = np.frombuffer(skeleton.angles, dtype="<f4").reshape(-1, 3)
    return {name: (float(r), float(p), float(y)) for name, (r, p, y) in zip(
        skeleton.joints, values, strict=True)}  # fmt: skip
