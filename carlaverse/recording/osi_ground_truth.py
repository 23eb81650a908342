"""A recording as ASAM OSI ground truth: one `osi3.GroundTruth` per tick of a fixed grid.

Moving objects are the participants' egos (`ego/<id>/pose`) and the authority's NPCs
(`world/npc`), a vehicle's lights from its latest light bits (NPC rows, `ego/<id>/state`;
`recording/osi_lights.py`); the weather from `world/weather` (`recording/osi_environment.py`);
lanes, boundaries and signal heads come from the recorded map
(`recording/osi_map.py`), signal states from `world/lights`; all of it read in one pass over
the recording (`recording/recorded_world.py`, shared with the analysis).

Frames. The project's world frame is OSI's global frame: x east, y north, z up, right-handed,
and its angles are OSI's too (ISO 8855 body axes x forward, y left, z up; yaw counter-clockwise
from +x, roll right side down, pitch nose down; docs/protocol.md), so positions, angles and
world-frame velocities pass through unchanged. Only the reference point differs: a pose is the
centre of the actor's footprint on the ground (analysis/footprints.py), OSI's `base.position`
the centre of its bounding box, half its height up the body's z axis.

Time. Ticks are `rate_hz` apart from the first sample of any actor, the grid the analysis uses
(analysis/tracks.py); each actor is linearly interpolated there between its own samples and is
absent before its first, after its last and across a gap longer than `max_gap_s`. An actor's
acceleration is what its poses carry; where they carry none (all zero: scripted nodes, NPCs),
it is the derivative of its recorded velocity. Timestamps are session time.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from osi3 import osi_version_pb2
from osi3.osi_groundtruth_pb2 import GroundTruth
from osi3.osi_object_pb2 import MovingObject

from carlaverse.recording.osi_environment import conditions
from carlaverse.recording.osi_lights import fill_light_state
from carlaverse.recording.osi_map import OsiIds, lanes, signal_heads, traffic_lights
from carlaverse.recording.osi_world import ANGLES, ActorTrack, Latest
from carlaverse.recording.recorded_world import COLUMN, RecordedWorld

VehicleType = MovingObject.VehicleClassification.Type
ACTOR_REFERENCE_TYPE = "net.carlaverse.actor"  # source_reference.type: identifier is the id

# actor kind (messages.ACTOR_KINDS) -> OSI object type, vehicle type (None: not a vehicle)
OSI_TYPES: dict[str, tuple[int, int | None]] = {
    "car": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_MEDIUM_CAR),
    "van": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_DELIVERY_VAN),
    "truck": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_HEAVY_TRUCK),
    "bus": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_BUS),
    "motorcycle": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_MOTORBIKE),
    "bicycle": (MovingObject.TYPE_VEHICLE, VehicleType.TYPE_BICYCLE),
    "pedestrian": (MovingObject.TYPE_PEDESTRIAN, None),
    "other": (MovingObject.TYPE_OTHER, None),
}


@dataclass(frozen=True)
class Options:
    rate_hz: float = 20.0  # [Hz] ground truths per second of session time
    max_gap_s: float = 0.5  # [s] an actor is absent across a longer gap between its samples
    host: str | None = None  # the host vehicle; default: the first ego
    map_every_frame: bool = False  # lanes and boundaries in every frame, not only the first


def tick_times(tracks: dict[str, ActorTrack], rate_hz: float) -> np.ndarray:
    """[s] the grid: `rate_hz` apart from the first sample of any actor to the last."""
    if not tracks:
        return np.zeros(0)
    start = min(tr.t[0] for tr in tracks.values())
    end = max(tr.t[-1] for tr in tracks.values())
    return start + np.arange(int(np.floor((end - start) * rate_hz)) + 1) / rate_hz


def ground_truths(world: RecordedWorld, options: Options = Options()) -> Iterator[GroundTruth]:
    """One GroundTruth per tick, in time order."""
    ids = OsiIds()
    road_lanes, boundaries = lanes(world.road_map, ids) if world.road_map else ([], [])
    heads = signal_heads(world.road_map, ids) if world.road_map else []
    signals = Latest(world.lights)
    weather = Latest([(t, conditions(w)) for t, w in world.weather])
    actors = _Actors(world, options, ids)
    for k, t in enumerate(tick_times(actors.tracks, options.rate_hz)):
        gt = _frame(float(t))
        actors.place(gt, float(t))
        if k == 0 or options.map_every_frame:
            gt.lane.extend(road_lanes)
            gt.lane_boundary.extend(boundaries)
        if (states := signals.at(float(t))) is not None:
            gt.traffic_light.extend(traffic_lights(heads, states))
        if (environment := weather.at(float(t))) is not None:
            gt.environmental_conditions.CopyFrom(environment)
        yield gt


class _Actors:
    """Every road user of the recording, placed into a frame at a time."""

    def __init__(self, world: RecordedWorld, options: Options, ids: OsiIds) -> None:
        self.order = world.actor_ids()
        self.ids = [ids.of("actor", a) for a in self.order]
        self.tracks = {a: ActorTrack(world.rows(a), options.max_gap_s) for a in self.order}
        self.templates = [
            _object_template(world, a, i) for a, i in zip(self.order, self.ids, strict=True)
        ]
        self.lights = [Latest(world.vehicle_lights.get(a, [])) for a in self.order]
        host = options.host or next((a for a in self.order if a in world.humans), None)
        self.host = ids.of("actor", host) if host is not None else None

    def place(self, gt: GroundTruth, t: float) -> None:
        for k, actor_id in enumerate(self.order):
            row = self.tracks[actor_id].at(t)
            if row is None:
                continue
            obj = gt.moving_object.add()
            _place(obj, self.templates[k], row)
            bits = self.lights[k].at(t)
            if obj.type == MovingObject.TYPE_VEHICLE and bits is not None:
                fill_light_state(obj.vehicle_classification.light_state, bits)
            if self.ids[k] == self.host:
                gt.host_vehicle_id.value = self.host


def interface_version() -> osi_version_pb2.InterfaceVersion:
    """The OSI release of the installed bindings (osi_version.proto's file option)."""
    options = osi_version_pb2.DESCRIPTOR.GetOptions()
    return options.Extensions[osi_version_pb2.current_interface_version]


def _frame(t: float) -> GroundTruth:
    gt = GroundTruth()
    gt.version.CopyFrom(interface_version())
    whole = math.floor(t)  # split first: t * 1e9 would lose the nanoseconds of an epoch time
    seconds, nanos = divmod(whole * 10**9 + round((t - whole) * 1e9), 10**9)
    gt.timestamp.seconds, gt.timestamp.nanos = seconds, nanos
    return gt


def _object_template(world: RecordedWorld, actor_id: str, osi_id: int) -> MovingObject:
    """What stays the same of an actor across frames: id, type, size, where it comes from."""
    obj = MovingObject()
    obj.id.value = osi_id
    kind = world.kind(actor_id)
    obj.type, vehicle_type = OSI_TYPES[kind]
    if vehicle_type is not None:
        obj.vehicle_classification.type = vehicle_type
    extent = world.extent(actor_id)
    d = obj.base.dimension
    d.length, d.width, d.height = extent.length, extent.width, extent.height
    obj.model_reference = kind
    ref = obj.source_reference.add()
    ref.type = ACTOR_REFERENCE_TYPE
    ref.identifier.append(actor_id)
    return obj


def _place(obj: MovingObject, template: MovingObject, row: np.ndarray) -> None:
    obj.CopyFrom(template)
    b = obj.base
    roll, pitch, yaw = (float(math.remainder(row[i], 2 * math.pi)) for i in ANGLES)
    up = _body_up(roll, pitch, yaw) * (b.dimension.height / 2)  # ground -> box centre
    b.position.x, b.position.y, b.position.z = (row[COLUMN[c]] + up[i] for i, c in enumerate("xyz"))
    b.orientation.roll, b.orientation.pitch, b.orientation.yaw = roll, pitch, yaw
    b.velocity.x, b.velocity.y, b.velocity.z = (
        row[COLUMN["vx"]],
        row[COLUMN["vy"]],
        row[COLUMN["vz"]],
    )
    b.acceleration.x, b.acceleration.y, b.acceleration.z = row[COLUMN["ax"] : COLUMN["az"] + 1]
    omega = row[COLUMN["wx"] : COLUMN["wz"] + 1]
    rate = b.orientation_rate
    rate.roll, rate.pitch, rate.yaw = _euler_rates(roll, pitch, yaw, omega)


def _rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll): body axes (columns) in the world frame."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))  # fmt: skip
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])  # fmt: skip


def _euler_rates(roll: float, pitch: float, yaw: float, omega: np.ndarray) -> tuple[float, ...]:
    """d(roll, pitch, yaw)/dt from the world-frame angular velocity `omega` [rad/s].

    OSI's orientation_rate is the rate of its angles, not an angular velocity: through the
    body rates (p, q, r) = R^T omega, the z-y'-x'' kinematics give roll' = p + (q sin roll +
    r cos roll) tan pitch, pitch' = q cos roll - r sin roll, yaw' = (q sin roll + r cos roll)
    / cos pitch. For a level body it is omega itself."""
    p, q, r = _rotation(roll, pitch, yaw).T @ omega
    turn = q * math.sin(roll) + r * math.cos(roll)
    return (float(p + turn * math.tan(pitch)), float(q * math.cos(roll) - r * math.sin(roll)),
            float(turn / math.cos(pitch)))  # fmt: skip


def _body_up(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The body's z axis in the world frame."""
    return _rotation(roll, pitch, yaw)[:, 2]
