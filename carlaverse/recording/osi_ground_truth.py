"""A recording as ASAM OSI ground truth: one `osi3.GroundTruth` per tick of a fixed grid.

Moving objects are the participants' egos (`ego/<id>/pose`) and the authority's NPCs
(`world/npc`), a vehicle's lights from its latest light bits (NPC rows, `ego/<id>/state`;
`recording/osi_lights.py`); lanes, boundaries and signal heads come from the recorded map
(`recording/osi_map.py`), signal states from `world/lights`.

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

import bisect
import math
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from osi3 import osi_version_pb2
from osi3.osi_groundtruth_pb2 import GroundTruth
from osi3.osi_object_pb2 import MovingObject

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.recording.osi_lights import ego_bits, fill_light_state
from carlaverse.recording.osi_map import OsiIds, lanes, signal_heads, traffic_lights
from carlaverse.recording.reading import iter_samples

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
# columns of an actor's sample rows
COLUMNS = ("t", "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz",
           "wx", "wy", "wz", "ax", "ay", "az")  # fmt: skip
_C = {name: i for i, name in enumerate(COLUMNS)}
_ANGLES = [_C["roll"], _C["pitch"], _C["yaw"]]


@dataclass
class RecordedWorld:
    """What one pass over a recording gives the OSI export."""

    samples: dict[str, list[np.ndarray]] = field(default_factory=lambda: defaultdict(list))
    kinds: dict[str, str] = field(default_factory=dict)
    extents: dict[str, m.Extent] = field(default_factory=dict)
    humans: set[str] = field(default_factory=set)
    lights: list[tuple[float, dict[str, str]]] = field(default_factory=list)  # (t, id -> state)
    # actor -> (t, messages.LIGHT_* bits) where they changed: NPC rows, an ego's EgoState
    vehicle_lights: dict[str, list[tuple[float, int]]] = field(
        default_factory=lambda: defaultdict(list)
    )
    road_map: m.MapReply | None = None
    skipped: int = 0  # samples of our keys that did not decode

    def actor_ids(self) -> list[str]:
        """Egos first, then NPCs, each sorted (the analysis's order)."""
        return sorted((a for a, rows in self.samples.items() if rows),
                      key=lambda a: (a not in self.humans, a))  # fmt: skip

    def kind(self, actor_id: str) -> str:
        kind = self.kinds.get(actor_id, "other")
        return kind if kind in OSI_TYPES else "other"

    def extent(self, actor_id: str) -> m.Extent:
        return self.extents.get(actor_id) or m.KIND_EXTENTS[self.kind(actor_id)]


def read_world(path: str | Path) -> RecordedWorld:
    """Actors' samples, kinds, extents, signal states and the map of a recording, in one pass."""
    world = RecordedWorld()
    for sample in iter_samples(path):
        if sample.kind != "put":
            continue
        try:
            _take(world, keyspace.parse(sample.key), sample.payload)
        except (keyspace.KeySpaceError, m.MessageError):
            world.skipped += 1  # a foreign or damaged sample says nothing about the world
    return world


def _take(world: RecordedWorld, key: keyspace.ParsedKey, payload: bytes) -> None:
    if key.area == "ego" and key.channel == "pose":
        p = m.POSE.decode(payload)
        world.samples[key.node_id].append(np.array([[p.t, p.x, p.y, p.z, p.roll, p.pitch, p.yaw,
            p.vx, p.vy, p.vz, p.wx, p.wy, p.wz, p.ax, p.ay, p.az]]))  # fmt: skip
        world.humans.add(key.node_id)
    elif key.area == "ego" and key.channel == "state":
        ego_state = m.EGO_STATE.decode(payload)
        world.vehicle_lights[key.node_id].append((ego_state.t, ego_bits(ego_state)))
    elif key.area == "world" and key.channel == "npc":
        _take_batch(world, m.NPC_BATCH.decode(payload))
    elif key.area == "world" and key.channel == "lights":
        state = m.LIGHTS.decode(payload)
        world.lights.append((state.t, {light.id: light.state for light in state.lights}))
    elif key.area == "world" and key.channel == "events":
        event = m.WORLD_EVENT.decode(payload)
        if isinstance(event, m.Spawned) and event.actor_kind:
            world.kinds[event.node_id] = event.actor_kind
    elif key.area == "authority" and key.channel == "map" and world.road_map is None:
        world.road_map = m.MAP.decode(payload)
    elif key.area == "authority" and key.channel == "snapshot":
        for ego in m.SNAPSHOT.decode(payload).egos:
            world.kinds[ego.node_id] = ego.actor_kind or world.kinds.get(ego.node_id, "other")
            world.extents[ego.node_id] = ego.extent


def _take_batch(world: RecordedWorld, batch: m.NpcBatch) -> None:
    rows = batch.array()
    table = np.zeros((len(rows), len(COLUMNS)))
    table[:, _C["t"]] = batch.t
    for name in ("x", "y", "z", "yaw", "vx", "vy"):
        table[:, _C[name]] = rows[name]
    table[:, _C["wz"]] = rows["yaw_rate"]
    for npc_id, row, source in zip(batch.ids, table, rows, strict=True):
        world.samples[npc_id].append(row[None, :])
        seen = world.vehicle_lights[npc_id]
        if not seen or seen[-1][1] != int(source["lights"]):
            seen.append((batch.t, int(source["lights"])))
        if npc_id not in world.extents and source["length"] > 0 and source["width"] > 0:
            size = (float(source["length"]), float(source["width"]), float(source["height"]))
            world.extents[npc_id] = m.Extent(*size) if size[2] > 0 else m.Extent(*size[:2])
            world.kinds[npc_id] = m.ACTOR_KINDS[min(int(source["kind"]), len(m.ACTOR_KINDS) - 1)]


class ActorTrack:
    """One actor's samples, sorted, with accelerations filled in where none were carried."""

    def __init__(self, chunks: list[np.ndarray], max_gap_s: float) -> None:
        rows = np.concatenate(chunks)
        rows = rows[np.argsort(rows[:, 0], kind="stable")]
        rows = rows[np.concatenate([[True], np.diff(rows[:, 0]) > 0])]  # one per instant
        rows[:, _ANGLES] = np.unwrap(rows[:, _ANGLES], axis=0)  # interpolate the short way
        self.max_gap_s = max_gap_s
        self.t = rows[:, 0]
        if not rows[:, _C["ax"] :].any():  # no acceleration carried: differentiate velocity
            rows[:, _C["ax"] :] = self._derivative(rows[:, _C["vx"] : _C["vz"] + 1])
        self.rows = rows

    def _derivative(self, values: np.ndarray) -> np.ndarray:
        """d values / dt within each stretch without a gap (0 for a lone sample)."""
        out = np.zeros_like(values)
        cuts = np.flatnonzero(np.diff(self.t) > self.max_gap_s) + 1
        for piece in np.split(np.arange(len(self.t)), cuts):
            if len(piece) > 1:
                out[piece] = np.gradient(values[piece], self.t[piece], axis=0)
        return out

    def at(self, t: float) -> np.ndarray | None:
        """The row interpolated at session time `t`, or None where the actor is absent."""
        if t < self.t[0] or t > self.t[-1]:
            return None
        after = min(max(1, bisect.bisect_left(self.t, t)), len(self.t) - 1)
        if len(self.t) == 1:
            return self.rows[0] if math.isclose(t, self.t[0]) else None
        t0, t1 = self.t[after - 1], self.t[after]
        if t1 - t0 > self.max_gap_s:
            return None
        w = (t - t0) / (t1 - t0)
        return self.rows[after - 1] * (1 - w) + self.rows[after] * w


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
    order = world.actor_ids()
    tracks = {a: ActorTrack(world.samples[a], options.max_gap_s) for a in order}
    objects = {a: _object_template(world, a, ids.of("actor", a)) for a in order}
    host = options.host or next((a for a in order if a in world.humans), None)
    light_times = [t for t, _ in world.lights]
    vehicle_lights = {a: sorted(world.vehicle_lights.get(a, [])) for a in order}
    for k, t in enumerate(tick_times(tracks, options.rate_hz)):
        gt = _frame(float(t))
        for actor_id in order:
            row = tracks[actor_id].at(float(t))
            if row is not None:
                obj = gt.moving_object.add()
                _place(obj, objects[actor_id], row)
                _light(obj, vehicle_lights[actor_id], float(t))
                if actor_id == host:
                    gt.host_vehicle_id.value = ids.of("actor", actor_id)
        if k == 0 or options.map_every_frame:
            gt.lane.extend(road_lanes)
            gt.lane_boundary.extend(boundaries)
        at = bisect.bisect_right(light_times, float(t)) - 1
        if at >= 0:
            gt.traffic_light.extend(traffic_lights(heads, world.lights[at][1]))
        yield gt


def _light(obj: MovingObject, changes: list[tuple[float, int]], t: float) -> None:
    """A vehicle's lights as its latest recorded bits at `t` say (none before the first)."""
    at = bisect.bisect_right(changes, (t, 1 << 62)) - 1
    if obj.type == MovingObject.TYPE_VEHICLE and at >= 0:
        fill_light_state(obj.vehicle_classification.light_state, changes[at][1])


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
    roll, pitch, yaw = (float(math.remainder(row[i], 2 * math.pi)) for i in _ANGLES)
    up = _body_up(roll, pitch, yaw) * (b.dimension.height / 2)  # ground -> box centre
    b.position.x, b.position.y, b.position.z = (row[_C[c]] + up[i] for i, c in enumerate("xyz"))
    b.orientation.roll, b.orientation.pitch, b.orientation.yaw = roll, pitch, yaw
    b.velocity.x, b.velocity.y, b.velocity.z = row[_C["vx"]], row[_C["vy"]], row[_C["vz"]]
    b.acceleration.x, b.acceleration.y, b.acceleration.z = row[_C["ax"] : _C["az"] + 1]
    omega = row[_C["wx"] : _C["wz"] + 1]
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
