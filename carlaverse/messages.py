"""Every message on the fabric, as frozen msgspec Structs, with codecs built once (DESIGN §4).

Wire format: MessagePack. Structs that travel at high rate are `array_like` (no field names on
the wire); the rest encode as maps so new fields can be added with defaults (msgspec schema
evolution: new fields go last and carry a default). The pose is the one exception: it has a
fixed 64-byte little-endian layout (`POSE_LAYOUT`), because msgspec writes every float as
8 bytes and the pose is the hottest message of all.

Conventions: world frame = the road network's frame (x east, y north, z up, metres); angles in
radians, yaw counter-clockwise from +x; times are session seconds (the authority's clock).

Decoding network input never raises anything but `MessageError` (a ValueError).
"""

from __future__ import annotations

import math
import struct
from typing import Any, Generic, Literal, TypeVar

import msgspec
import numpy as np

SCHEMA_VERSION = 1

T = TypeVar("T")


class MessageError(ValueError):
    """A payload that does not decode into the expected message type."""


# --------------------------------------------------------------------------- pose

POSE_LAYOUT_VERSION = 1
# version u8, flags u8, reserved u16, seq u32, t f64, position 3×f32, rotation (roll, pitch,
# yaw) 3×f32, velocity 3×f32, angular velocity 3×f16, acceleration 3×f16  = 64 bytes.
# float32 keeps millimetres up to ~16 km from the origin; f16 keeps rates to ~0.1 %.
POSE_LAYOUT = struct.Struct("<BBHId3f3f3f3e3e")
POSE_SIZE = POSE_LAYOUT.size
POSE_FLAG_TELEPORT = 0x01  # receivers snap instead of blending (respawn, reset)


class Pose(msgspec.Struct, frozen=True, array_like=True):
    """Ego pose telemetry sample; the node id travels in the key, not here."""

    seq: int
    t: float  # [s] session time the pose is valid at
    x: float  # [m]
    y: float  # [m]
    z: float = 0.0  # [m]
    roll: float = 0.0  # [rad]
    pitch: float = 0.0  # [rad]
    yaw: float = 0.0  # [rad]
    vx: float = 0.0  # [m/s] world frame
    vy: float = 0.0  # [m/s]
    vz: float = 0.0  # [m/s]
    wx: float = 0.0  # [rad/s] world frame
    wy: float = 0.0  # [rad/s]
    wz: float = 0.0  # [rad/s] yaw rate
    ax: float = 0.0  # [m/s²] world frame
    ay: float = 0.0  # [m/s²]
    az: float = 0.0  # [m/s²]
    flags: int = 0


def encode_pose(p: Pose) -> bytes:
    try:
        return POSE_LAYOUT.pack(
            POSE_LAYOUT_VERSION, p.flags, 0, p.seq & 0xFFFFFFFF, p.t,
            p.x, p.y, p.z, p.roll, p.pitch, p.yaw, p.vx, p.vy, p.vz,
            p.wx, p.wy, p.wz, p.ax, p.ay, p.az,
        )  # fmt: skip
    except (struct.error, OverflowError) as exc:
        raise MessageError(f"pose does not fit the wire layout: {exc}") from exc


def decode_pose(buf: bytes | bytearray | memoryview) -> Pose:
    if len(buf) != POSE_SIZE:
        raise MessageError(f"pose: expected {POSE_SIZE} bytes, got {len(buf)}")
    v = POSE_LAYOUT.unpack(buf)
    if v[0] != POSE_LAYOUT_VERSION:
        raise MessageError(f"pose: unknown layout version {v[0]}")
    values = v[4:]
    if not all(math.isfinite(f) for f in values):
        raise MessageError("pose: non-finite value")
    return Pose(v[3], *values, flags=v[1])


# --------------------------------------------------------------------------- ego state

Indicator = Literal["off", "left", "right", "hazard"]

# Light bits, shared by egos and NPC batches.
LIGHT_PARKING = 0x01
LIGHT_LOW_BEAM = 0x02
LIGHT_HIGH_BEAM = 0x04
LIGHT_FOG = 0x08
LIGHT_BRAKE = 0x10
LIGHT_REVERSE = 0x20
LIGHT_INTERIOR = 0x40
LIGHT_LEFT_BLINKER = 0x80
LIGHT_RIGHT_BLINKER = 0x100


class EgoState(msgspec.Struct, frozen=True):
    """Discrete vehicle/rider state, published on change (reliable)."""

    seq: int
    t: float
    lights: int = 0
    indicator: Indicator = "off"
    gear: int = 0  # -1 reverse, 0 neutral, 1.. forward
    speed_mps: float = 0.0
    adas: str = ""  # active override source, "" when the human drives alone


class Override(msgspec.Struct, frozen=True):
    """ADAS override injected by an external program on ego/<id>/override."""

    seq: int
    t: float
    source: str  # e.g. "acc-study-v2"
    active: bool = True
    cruise_speed_mps: float | None = None
    lane_keep_torque_nm: float | None = None
    expires_t: float | None = None  # [s] session time after which the override lapses


class Skeleton(msgspec.Struct, frozen=True, array_like=True):
    """Avatar joint angles from a walk node (~30 Hz)."""

    seq: int
    t: float
    joints: list[str]
    angles: bytes  # float32 little-endian, 3 per joint (roll, pitch, yaw) [rad]


# --------------------------------------------------------------------------- world

ACTOR_KINDS = ("car", "van", "truck", "bus", "motorcycle", "bicycle", "pedestrian", "other")

# One NPC row; batches carry `numpy` structured arrays of this dtype as bytes.
NPC_DTYPE = np.dtype(
    [
        ("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("yaw", "<f4"),
        ("vx", "<f4"), ("vy", "<f4"), ("yaw_rate", "<f4"),
        ("length", "<f4"), ("width", "<f4"), ("height", "<f4"),
        ("kind", "u1"), ("reserved", "u1"), ("lights", "<u2"),
    ]
)  # fmt: skip


class NpcBatch(msgspec.Struct, frozen=True, array_like=True):
    """All NPCs at one instant, packed as arrays rather than one message per NPC."""

    seq: int
    t: float
    ids: list[str]
    rows: bytes  # len(ids) rows of NPC_DTYPE

    def array(self) -> np.ndarray:
        """The rows as a structured array (read-only view of the payload)."""
        return np.frombuffer(self.rows, dtype=NPC_DTYPE)

    @classmethod
    def pack(cls, seq: int, t: float, ids: list[str], rows: np.ndarray) -> NpcBatch:
        return cls(seq, t, ids, np.ascontiguousarray(rows, dtype=NPC_DTYPE).tobytes())


class TrafficLight(msgspec.Struct, frozen=True, array_like=True):
    id: str
    state: str  # one char per controlled link, SUMO style: r y g G o O s u
    phase: int
    remaining_s: float  # [s] until the next phase switch


class LightsState(msgspec.Struct, frozen=True):
    seq: int
    t: float
    lights: list[TrafficLight]


class Weather(msgspec.Struct, frozen=True):
    seq: int
    t: float
    sun_altitude_deg: float = 45.0
    sun_azimuth_deg: float = 180.0
    cloudiness: float = 0.0  # 0..1
    precipitation: float = 0.0  # 0..1
    fog_density: float = 0.0  # 0..1
    wetness: float = 0.0  # 0..1
    wind_speed_mps: float = 0.0
    wind_direction_deg: float = 0.0


class Spawned(msgspec.Struct, frozen=True, tag="spawned"):
    seq: int
    t: float
    node_id: str
    kind: str


class Despawned(msgspec.Struct, frozen=True, tag="despawned"):
    seq: int
    t: float
    node_id: str
    reason: str  # "left" | "timeout" | "liveliness" | "authority"


class ContactStarted(msgspec.Struct, frozen=True, tag="contact_started"):
    seq: int
    t: float
    contact_id: int
    a: str
    b: str
    relative_speed_mps: float = 0.0


class ContactEnded(msgspec.Struct, frozen=True, tag="contact_ended"):
    seq: int
    t: float
    contact_id: int
    a: str
    b: str


WorldEvent = Spawned | Despawned | ContactStarted | ContactEnded


class Impulse(msgspec.Struct, frozen=True):
    """Collision impulse for one ego, decided by the authority."""

    seq: int
    t: float  # [s] session time at which to apply it
    contact_id: int
    impulse: tuple[float, float, float]  # [N·s] world frame, acting on this ego
    point: tuple[float, float, float]  # [m] contact point, world frame
    normal: tuple[float, float, float]  # unit, pointing from the other actor into this ego
    other_id: str
    other_kind: str
    relative_speed_mps: float


# --------------------------------------------------------------------------- queries


class Extent(msgspec.Struct, frozen=True, array_like=True):
    length: float = 4.5  # [m]
    width: float = 1.8  # [m]
    height: float = 1.5  # [m]


class SpawnPoint(msgspec.Struct, frozen=True, array_like=True):
    x: float
    y: float
    z: float = 0.0
    yaw: float = 0.0


class JoinRequest(msgspec.Struct, frozen=True):
    schema: int
    node_id: str
    instance: str  # random per process run: tells a re-join from a duplicate id
    kind: str  # node kind: drive, bike, walk, scripted, observer ...
    actor_kind: str = "car"  # one of ACTOR_KINDS; observers have no actor
    extent: Extent = Extent()
    mass_kg: float = 1500.0
    site: str = ""
    hostname: str = ""
    version: str = ""
    pose_rate_hz: float = 50.0
    config_yaml: str = ""  # the node's effective config, archived with recordings


class JoinReply(msgspec.Struct, frozen=True):
    schema: int
    accepted: bool
    reason: str = ""
    session: str = ""
    spawn: SpawnPoint | None = None
    despawn_timeout_s: float = 3.0
    tick_hz: float = 50.0
    authority_instance: str = ""


class ClockRequest(msgspec.Struct, frozen=True):
    node_id: str = ""


class ClockReply(msgspec.Struct, frozen=True, array_like=True):
    t: float  # [s] session time when the authority answered
    known: bool = False  # whether the asking node is currently joined


class EgoInfo(msgspec.Struct, frozen=True):
    node_id: str
    kind: str
    actor_kind: str
    extent: Extent
    mass_kg: float
    site: str = ""
    pose: Pose | None = None
    state: EgoState | None = None


class Snapshot(msgspec.Struct, frozen=True):
    schema: int
    t: float
    egos: list[EgoInfo]
    npc: NpcBatch | None = None
    lights: LightsState | None = None
    weather: Weather | None = None


class MapLane(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # road | sidewalk | bike | crossing | walkingarea | rail
    width: float  # [m]
    centerline: list[tuple[float, float]]  # [m]
    allow: list[str] = []


class MapArea(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # junction | vegetation | water | building
    polygon: list[tuple[float, float]]


class MapLight(msgspec.Struct, frozen=True, array_like=True):
    id: str  # traffic light (SUMO tls) id
    position: tuple[float, float]
    controlled_lanes: list[str]  # one entry per link index of the light's state string


class MapReply(msgspec.Struct, frozen=True):
    schema: int
    name: str
    bounds: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax [m]
    lanes: list[MapLane]
    areas: list[MapArea] = []
    lights: list[MapLight] = []


class ScenarioReply(msgspec.Struct, frozen=True):
    schema: int
    name: str
    yaml: str  # the scenario file as run, byte-for-byte
    seed: int = 0


class ConfigsReply(msgspec.Struct, frozen=True):
    """Every joined node's effective config, for archiving with a recording."""

    schema: int
    nodes: dict[str, str]  # node id -> config YAML as the node sent it at join
    scenario_yaml: str = ""
    hostnames: dict[str, str] = {}  # node id -> host it joined from


# --------------------------------------------------------------------------- codecs


class Codec(Generic[T]):
    """Encoder and decoder for one message type, built once."""

    def __init__(self, type_: Any) -> None:
        self.type = type_
        self._encoder = msgspec.msgpack.Encoder()
        self._decoder = msgspec.msgpack.Decoder(type_)

    def encode(self, msg: T) -> bytes:
        return self._encoder.encode(msg)

    def decode(self, buf: bytes | bytearray | memoryview) -> T:
        try:
            return self._decoder.decode(buf)
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise MessageError(f"{_type_name(self.type)}: {exc}") from exc


class PoseCodec(Codec[Pose]):
    def __init__(self) -> None:
        self.type = Pose

    def encode(self, msg: Pose) -> bytes:
        return encode_pose(msg)

    def decode(self, buf: bytes | bytearray | memoryview) -> Pose:
        return decode_pose(buf)


def _type_name(type_: Any) -> str:
    return getattr(type_, "__name__", None) or str(type_)


POSE = PoseCodec()
EGO_STATE: Codec[EgoState] = Codec(EgoState)
OVERRIDE: Codec[Override] = Codec(Override)
SKELETON: Codec[Skeleton] = Codec(Skeleton)
NPC_BATCH: Codec[NpcBatch] = Codec(NpcBatch)
LIGHTS: Codec[LightsState] = Codec(LightsState)
WEATHER: Codec[Weather] = Codec(Weather)
WORLD_EVENT: Codec[WorldEvent] = Codec(WorldEvent)
IMPULSE: Codec[Impulse] = Codec(Impulse)
JOIN_REQUEST: Codec[JoinRequest] = Codec(JoinRequest)
JOIN_REPLY: Codec[JoinReply] = Codec(JoinReply)
CLOCK_REQUEST: Codec[ClockRequest] = Codec(ClockRequest)
CLOCK_REPLY: Codec[ClockReply] = Codec(ClockReply)
SNAPSHOT: Codec[Snapshot] = Codec(Snapshot)
MAP: Codec[MapReply] = Codec(MapReply)
SCENARIO: Codec[ScenarioReply] = Codec(ScenarioReply)
CONFIGS: Codec[ConfigsReply] = Codec(ConfigsReply)

# What travels on each key (area, channel) — recorders and validators look types up here.
CHANNEL_CODECS: dict[tuple[str, str], Codec[Any]] = {
    ("ego", "pose"): POSE,
    ("ego", "state"): EGO_STATE,
    ("ego", "override"): OVERRIDE,
    ("ego", "skeleton"): SKELETON,
    ("world", "npc"): NPC_BATCH,
    ("world", "lights"): LIGHTS,
    ("world", "weather"): WEATHER,
    ("world", "events"): WORLD_EVENT,
    ("impulse", ""): IMPULSE,
    ("authority", "join"): JOIN_REPLY,
    ("authority", "clock"): CLOCK_REPLY,
    ("authority", "snapshot"): SNAPSHOT,
    ("authority", "map"): MAP,
    ("authority", "scenario"): SCENARIO,
    ("authority", "configs"): CONFIGS,
}
