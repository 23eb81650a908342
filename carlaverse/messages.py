"""Every message on the fabric, as frozen msgspec Structs, with codecs built once
(docs/architecture.md §4).

Wire format: MessagePack. Structs that travel at high rate are `array_like` (no field names on
the wire); the rest encode as maps so new fields can be added with defaults (msgspec schema
evolution: new fields go last and carry a default). The pose is the one exception: it has a
fixed 64-byte little-endian layout (`POSE_LAYOUT`), because msgspec writes every float as
8 bytes and the pose is the hottest message of all.

Conventions: world frame = the road network's frame (x east, y north, z up, metres); angles in
radians, yaw counter-clockwise from +x; times are session seconds (the authority's clock).

Decoding network input never raises anything but `MessageError` (a ValueError), whatever is
wrong with it: malformed MessagePack, deep nesting, bad UTF-8, a value out of range — even in a
field this version does not know. Every float on the wire is finite and every integer fits an
int64 (the constrained types below); a message that cannot be encoded raises `MessageError` too.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from typing import Annotated, Any, Generic, Literal, NamedTuple, TypeVar, cast, get_args

import msgspec
import numpy as np

from carlaverse.keys import DIGEST_CHANNEL
from carlaverse.patterns import anchored

# 2: the snapshot's pose is the 64-byte pose layout; `spawned` carries the actor kind;
#    the `authority/leave` query; despawn reasons are a closed set.
# 3: spatial keys: poses on `ego/<id>/pose/<tile>`, NPC batches also per tile.
SCHEMA_VERSION = 3

T = TypeVar("T")


class MessageError(ValueError):
    """A payload that does not decode into the expected message type."""


# Constrained wire types: a NaN, an infinity or an integer that overflows int64 is refused at
# decode time with the field's path, so no consumer (physics, recorder, renderer) ever sees one.
FLOAT_LIMIT = 1e15  # any physical quantity here is far smaller; NaN fails every bound
TIME_LIMIT_S = 1e12  # [s] session times are Unix-aligned (~1.7e9 s today)
Finite = Annotated[float, msgspec.Meta(ge=-FLOAT_LIMIT, le=FLOAT_LIMIT)]
Time = Annotated[float, msgspec.Meta(ge=-TIME_LIMIT_S, le=TIME_LIMIT_S)]  # [s] session time
Seq = Annotated[int, msgspec.Meta(ge=0, le=2**63 - 1)]
Int64 = Annotated[int, msgspec.Meta(ge=-(2**63), le=2**63 - 1)]
Vec3 = tuple[Finite, Finite, Finite]


# --------------------------------------------------------------------------- pose

POSE_LAYOUT_VERSION = 1
# version u8, flags u8, reserved u16, seq u32, t f64, position 3×f32, rotation (roll, pitch,
# yaw) 3×f32, velocity 3×f32, angular velocity 3×f16, acceleration 3×f16  = 64 bytes.
# float32 keeps millimetres up to ~16 km from the origin; f16 keeps rates to ~0.1 %.
POSE_LAYOUT = struct.Struct("<BBHId3f3f3f3e3e")
POSE_SIZE = POSE_LAYOUT.size
POSE_FLAG_TELEPORT = 0x01  # receivers snap instead of blending (respawn, reset)


class Pose(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """Ego pose telemetry sample; the node id travels in the key, not here.

    Untracked by the cyclic collector (`gc=False`: numbers only, so never in a cycle): a node
    hearing 256 egos holds some 25,000 of them in its buffers and makes 12,800 a second,
    which otherwise each collection walks and each allocation counts toward.

    Angles are ISO 8855 (x forward, y left, z up; right-handed): roll positive puts the right
    side down (a bike leaning left has roll < 0), pitch positive the nose down, yaw
    counter-clockwise from +x. Every consumer (renderer, Rerun, CARLA bridge) reads them so."""

    seq: int
    t: float  # [s] session time the pose is valid at
    x: float  # [m]
    y: float  # [m]
    z: float = 0.0  # [m]
    roll: float = 0.0  # [rad] ISO 8855: right side down positive
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


def encode_pose(p: Pose, seq: int | None = None) -> bytes:
    """The 64-byte wire form of `p`, with `seq` instead of `p.seq` when given (a publisher
    numbering its samples saves building a second Pose)."""
    seq = p.seq if seq is None else seq
    try:
        return POSE_LAYOUT.pack(
            POSE_LAYOUT_VERSION, p.flags, 0, seq & 0xFFFFFFFF, p.t,
            p.x, p.y, p.z, p.roll, p.pitch, p.yaw, p.vx, p.vy, p.vz,
            p.wx, p.wy, p.wz, p.ax, p.ay, p.az,
        )  # fmt: skip
    except (struct.error, OverflowError, TypeError) as exc:
        raise MessageError(f"pose does not fit the wire layout: {exc}") from exc


def _checked_pose_fields(buf: bytes | bytearray | memoryview) -> tuple[Any, ...]:
    """The wire pose's fields, unpacked, once the receiver's checks pass (layout, every value
    finite, the time in range); MessageError naming what failed otherwise."""
    if len(buf) != POSE_SIZE:
        raise MessageError(f"pose: expected {POSE_SIZE} bytes, got {len(buf)}")
    v = POSE_LAYOUT.unpack(buf)
    if v[0] != POSE_LAYOUT_VERSION:
        raise MessageError(f"pose: unknown layout version {v[0]}")
    # One sum instead of 18 checks: a NaN or an infinity in any field makes it non-finite,
    # and finite fields cannot overflow it (f32/f16 ranges; an absurd time is refused anyway).
    if not math.isfinite(sum(v[4:])):
        raise MessageError("pose: non-finite value")
    if abs(v[4]) > TIME_LIMIT_S:
        raise MessageError(f"pose: time {v[4]!r} s is out of range")
    return v


def decode_pose(buf: bytes | bytearray | memoryview) -> Pose:
    v = _checked_pose_fields(buf)
    # The layout unpacks into exactly Pose's positional fields after `seq`, so `flags` is never
    # filled twice; mypy cannot count a slice of the unpacked tuple.
    return Pose(v[3], *v[4:], flags=v[1])  # type: ignore[misc]


_POSE_STAMP = struct.Struct("<4xId")  # seq u32 at byte 4, t f64 at byte 8 (POSE_LAYOUT)


def pose_stamp(buf: bytes | bytearray | memoryview) -> tuple[int, float]:
    """The sequence number and time of a wire pose, read without decoding the rest."""
    seq, t = _POSE_STAMP.unpack_from(buf)
    return seq, t


# POSE_LAYOUT as a numpy record, no padding: 64 bytes. Many poses are checked at once with it.
POSE_DTYPE = np.dtype(
    [
        ("version", "u1"),
        ("flags", "u1"),
        ("reserved", "<u2"),
        ("seq", "<u4"),
        ("t", "<f8"),
        ("f32", "<f4", 9),  # x y z, roll pitch yaw, vx vy vz
        ("f16", "<f2", 6),  # wx wy wz, ax ay az
    ]
)
assert POSE_DTYPE.itemsize == POSE_SIZE


class PoseColumns(NamedTuple):
    """Consecutive poses as columns: what a receiver applies many at once."""

    seq: np.ndarray  # int64
    values: np.ndarray  # float64, (n, 16): t, x y z, roll pitch yaw, vx vy vz, wx wy wz, ax ay az
    flags: np.ndarray  # int64

    def take(self, rows: np.ndarray) -> PoseColumns:
        """Only these rows (indices or a mask)."""
        return PoseColumns(self.seq[rows], self.values[rows], self.flags[rows])

    def poses(self) -> list[Pose]:
        """A `Pose` per row, built column by column without a Python loop."""
        return list(map(Pose, self.seq.tolist(), *self.values.T.tolist(), self.flags.tolist()))


def pose_columns(rows: bytes | bytearray | memoryview) -> tuple[PoseColumns, np.ndarray]:
    """Consecutive 64-byte poses as columns, and which rows `decode_pose` would accept (layout
    version, every value finite, the time in range). One numpy pass over all of them."""
    if len(rows) % POSE_SIZE:
        raise MessageError(f"pose rows: {len(rows)} bytes is not a multiple of {POSE_SIZE}")
    table = np.frombuffer(rows, dtype=POSE_DTYPE)
    values = np.empty((len(table), 16))  # t, then the 9 f32 and 6 f16 fields, as f64
    values[:, 0] = table["t"]
    values[:, 1:10] = table["f32"]
    values[:, 10:] = table["f16"]
    good = (
        (table["version"] == POSE_LAYOUT_VERSION)
        & np.isfinite(values).all(axis=1)
        & (np.abs(values[:, 0]) <= TIME_LIMIT_S)
    )
    columns = PoseColumns(table["seq"].astype(np.int64), values, table["flags"].astype(np.int64))
    return columns, good


def pose_stamps(rows: bytes | bytearray | memoryview) -> tuple[np.ndarray, np.ndarray]:
    """The sequence numbers and times of consecutive wire poses, read without checking them."""
    table = np.frombuffer(rows, dtype=POSE_DTYPE)
    return table["seq"], table["t"]


# Up to this many rows are decoded one `struct` unpack each: numpy's setup for a pass over the
# rows costs more than that (measured warm: 1 row 10 µs through numpy against 1.4 µs unpacked,
# 8 rows 12 against 9, 16 rows 15 against 19). A node's loop applies a few poses per update.
FEW_ROWS = 8


def decode_pose_rows(rows: bytes | bytearray | memoryview) -> list[Pose | None]:
    """Consecutive 64-byte poses, each decoded as `decode_pose` would; None where it would
    refuse. A relay's batch costs a fraction of a `decode_pose` call per pose."""
    if len(rows) == POSE_SIZE:  # one pose per update: a node hearing one ego at its own rate
        return [_pose_or_none(rows)]
    if len(rows) <= FEW_ROWS * POSE_SIZE and not len(rows) % POSE_SIZE:
        return [_pose_or_none(rows[k : k + POSE_SIZE]) for k in range(0, len(rows), POSE_SIZE)]
    columns, good = pose_columns(rows)
    if good.all():  # nearly always
        return cast("list[Pose | None]", columns.poses())  # a new list, held by nobody else
    keep = np.flatnonzero(good)
    poses = columns.take(keep).poses()
    out: list[Pose | None] = [None] * len(good)
    for k, pose in zip(keep.tolist(), poses, strict=True):
        out[k] = pose
    return out


def _pose_or_none(row: bytes | bytearray | memoryview) -> Pose | None:
    try:
        return decode_pose(row)
    except MessageError:
        return None


# Poses relayed many to a message (`PoseDigest`): at most this many in one.
DIGEST_MAX_POSES = 4096


class PoseDigest(msgspec.Struct, frozen=True, array_like=True):
    """Egos' poses relayed by the authority, many to a message (`world/@egos`).

    For nodes that hear the whole session (docs/architecture.md §3): one sample for dozens of
    poses instead of one each, which is most of what a pose costs to receive. Each row is the
    pose exactly as its node published it."""

    seq: Seq
    ids: Annotated[list[str], msgspec.Meta(max_length=DIGEST_MAX_POSES)]  # row i's node
    rows: bytes  # len(ids) poses in the 64-byte pose layout

    def poses(self) -> list[Pose | None]:
        """Each row decoded; None for a row `decode_pose` would refuse."""
        return decode_pose_rows(self.rows)


def _check_pose_digest(digest: PoseDigest) -> None:
    if len(digest.rows) != len(digest.ids) * POSE_SIZE:
        raise MessageError(
            f"pose digest: {len(digest.ids)} ids but {len(digest.rows)} bytes of rows "
            f"(expected {len(digest.ids) * POSE_SIZE})"
        )


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

    seq: Seq
    t: Time
    lights: Int64 = 0
    indicator: Indicator = "off"
    gear: Int64 = 0  # -1 reverse, 0 neutral, 1.. forward
    speed_mps: Finite = 0.0
    adas: str = ""  # active override source, "" when the human drives alone


class Override(msgspec.Struct, frozen=True):
    """ADAS override injected by an external program on ego/<id>/override."""

    seq: Seq
    t: Time
    source: str  # e.g. "acc-study-v2"
    active: bool = True
    cruise_speed_mps: Finite | None = None
    lane_keep_torque_nm: Finite | None = None
    expires_t: Time | None = None  # [s] session time after which the override lapses


class Skeleton(msgspec.Struct, frozen=True, array_like=True):
    """Avatar joint angles from a walk node (~30 Hz)."""

    seq: Seq
    t: Time
    joints: list[str]
    angles: bytes  # float32 little-endian, 3 per joint (roll, pitch, yaw) [rad]


def _check_skeleton(skeleton: Skeleton) -> None:
    need = 12 * len(skeleton.joints)
    if len(skeleton.angles) != need:
        raise MessageError(f"skeleton: {len(skeleton.joints)} joints need {need} bytes of angles, "
                           f"got {len(skeleton.angles)}")  # fmt: skip


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
_NPC_FLOAT_FIELDS = [name for name in NPC_DTYPE.names or () if NPC_DTYPE[name].kind == "f"]


class NpcBatch(msgspec.Struct, frozen=True, array_like=True):
    """All NPCs at one instant, packed as arrays rather than one message per NPC."""

    seq: Seq
    t: Time
    ids: list[str]
    rows: bytes  # len(ids) rows of NPC_DTYPE

    def array(self) -> np.ndarray:
        """The rows as a structured array (read-only view of the payload)."""
        return np.frombuffer(self.rows, dtype=NPC_DTYPE)

    @classmethod
    def pack(cls, seq: int, t: float, ids: list[str], rows: np.ndarray) -> NpcBatch:
        return cls(seq, t, ids, np.ascontiguousarray(rows, dtype=NPC_DTYPE).tobytes())


def _check_npc_batch(batch: NpcBatch) -> None:
    if len(batch.rows) != len(batch.ids) * NPC_DTYPE.itemsize:
        raise MessageError(f"npc batch: {len(batch.ids)} ids but {len(batch.rows)} bytes of rows")
    rows = batch.array()
    if not all(np.isfinite(rows[f]).all() for f in _NPC_FLOAT_FIELDS):
        raise MessageError("npc batch: non-finite value in the rows")


class TrafficLight(msgspec.Struct, frozen=True, array_like=True):
    id: str
    state: str  # one char per controlled link, SUMO style: r y g G o O s u
    phase: Int64
    remaining_s: Finite  # [s] until the next phase switch


class LightsState(msgspec.Struct, frozen=True):
    seq: Seq
    t: Time
    lights: list[TrafficLight]


class Weather(msgspec.Struct, frozen=True):
    seq: Seq
    t: Time
    sun_altitude_deg: Finite = 45.0
    sun_azimuth_deg: Finite = 180.0  # compass bearing: 0 north, 90 east (clockwise)
    cloudiness: Finite = 0.0  # 0..1
    precipitation: Finite = 0.0  # 0..1
    fog_density: Finite = 0.0  # 0..1
    wetness: Finite = 0.0  # 0..1
    wind_speed_mps: Finite = 0.0  # [m/s]
    wind_direction_deg: Finite = 0.0  # compass bearing it blows FROM: 0 north, 90 east (clockwise)


class Spawned(msgspec.Struct, frozen=True, tag="spawned"):
    """A node joined: its actor (if any) is in the world from now on."""

    seq: Seq
    t: Time
    node_id: str
    kind: str  # the node kind (drive, scripted, observer ...)
    actor_kind: str = ""  # one of ACTOR_KINDS; "" for a node without an actor (observer)


# Why a node left the session: it said so (`authority/leave`); its liveliness token was lost
# (lease expiry, a crash); its telemetry went silent for the despawn timeout; the authority
# removed it (a re-join from a new process under the same id replaces the old one).
DespawnReason = Literal["left", "liveliness", "timeout", "authority"]


class Despawned(msgspec.Struct, frozen=True, tag="despawned"):
    """A node left the world, and why."""

    seq: Seq
    t: Time
    node_id: str
    reason: DespawnReason


class ContactStarted(msgspec.Struct, frozen=True, tag="contact_started"):
    """Two actors' boxes began to touch (one contact, until it ends)."""

    seq: Seq
    t: Time
    contact_id: Int64
    a: str
    b: str
    relative_speed_mps: Finite = 0.0


class ContactEnded(msgspec.Struct, frozen=True, tag="contact_ended"):
    """Two actors' boxes no longer touch."""

    seq: Seq
    t: Time
    contact_id: Int64
    a: str
    b: str


class TriggerFired(msgspec.Struct, frozen=True, tag="trigger"):
    """A scenario trigger's condition held and its actions ran (recorded for the analysis)."""

    seq: Seq
    t: Time
    trigger_id: str
    actions: list[str]  # what was done, e.g. "release waiting-car", "light C GrGr"
    # the trigger's measurements when it fired; None where not finite (no ETA, no TTC)
    values: dict[str, Finite | None] = {}


class Notice(msgspec.Struct, frozen=True, tag="notice"):
    """Text for a participant's HMI, from a scenario trigger."""

    seq: Seq
    t: Time
    text: str
    to: str = ""  # a node id, or "" for every participant
    duration_s: Finite = 5.0  # [s] how long it stays up


WorldEvent = Spawned | Despawned | ContactStarted | ContactEnded | TriggerFired | Notice


class Impulse(msgspec.Struct, frozen=True):
    """Collision impulse for one ego, decided by the authority."""

    seq: Seq
    t: Time  # [s] session time at which to apply it
    contact_id: Int64
    impulse: Vec3  # [N·s] world frame, acting on this ego
    point: Vec3  # [m] contact point, world frame
    normal: Vec3  # unit, pointing from the other actor into this ego
    other_id: str
    other_kind: str
    relative_speed_mps: Finite


# --------------------------------------------------------------------------- audio

# What makes a sound (docs/architecture.md §14). Point sources (engine, tyres, siren) sit on an
# actor; area sources (construction, leaves, water) sit at the point of their area nearest the
# listener with `extent_m` its radius; weather sources (rain, wind) surround the listener.
AudioKind = Literal["engine", "tyres", "siren", "construction", "leaves", "water", "rain", "wind"]
AUDIO_KINDS: tuple[str, ...] = get_args(AudioKind)
# Siren patterns (`drive_a` of a siren): how the renderer sweeps its tone.
SIREN_PATTERNS = ("wail", "yelp", "hi-lo")
AUDIO_LEVEL_LIMIT_DB = 200.0  # [dB SPL] far above any real source (a jet at 1 m is ~150 dB)
AUDIO_MAX_EMITTERS = 256  # per scene; the authority's per-node cap is far lower (config)
AUDIO_MAX_RPM = 30_000.0  # [1/min]
# What `drive_a` and `drive_b` mean, per kind; "-" = unused, sent as 0.
AUDIO_DRIVE_MEANING: dict[str, tuple[str, str]] = {
    "engine": ("engine speed [rpm]", "load 0..1"),
    "tyres": ("rolling speed [m/s]", "road wetness 0..1"),
    "siren": ("pattern: index into SIREN_PATTERNS", "-"),
    "construction": ("intensity 0..1", "-"),
    "leaves": ("intensity 0..1", "-"),
    "water": ("intensity 0..1", "-"),
    "rain": ("intensity 0..1", "-"),
    "wind": ("intensity 0..1", "-"),
}
Level = Annotated[float, msgspec.Meta(ge=-AUDIO_LEVEL_LIMIT_DB, le=AUDIO_LEVEL_LIMIT_DB)]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0, le=FLOAT_LIMIT)]


# gc=False: hundreds are made per audio instant and they hold no references (no cycles), so
# keeping them out of the cycle collector spares the authority's tick its collection pauses.
class AudioEmitter(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """One sound source for one listener; `drive_a`/`drive_b` mean what AUDIO_DRIVE_MEANING says."""

    id: str  # stable per source across scenes, e.g. "veh12.engine"
    kind: AudioKind
    x: Finite  # [m] world frame
    y: Finite  # [m]
    z: Finite  # [m]
    vx: Finite  # [m/s] world frame (Doppler)
    vy: Finite  # [m/s]
    vz: Finite  # [m/s]
    level_db: Level  # [dB SPL] sound pressure level at 1 m from the source
    extent_m: NonNegative = 0.0  # [m] radius of an area source; 0 = a point
    drive_a: Finite = 0.0  # kind-specific, see AUDIO_DRIVE_MEANING
    drive_b: Finite = 0.0  # kind-specific, see AUDIO_DRIVE_MEANING


class AudioScene(msgspec.Struct, frozen=True):
    """What one listener can hear at one instant, loudest first, on `audio/<listener>` (~20 Hz)."""

    seq: Seq
    t: Time
    listener: str  # the node id this scene was computed for (= the key's id)
    emitters: list[AudioEmitter] = []


def _check_audio_scene(scene: AudioScene) -> None:
    if len(scene.emitters) > AUDIO_MAX_EMITTERS:
        raise MessageError(f"audio scene: {len(scene.emitters)} emitters, "
                           f"at most {AUDIO_MAX_EMITTERS}")  # fmt: skip
    for e in scene.emitters:
        _check_drive(e)


_UNIT_RANGE = (0.0, 1.0)
_DRIVE_RANGES: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "engine": ((0.0, AUDIO_MAX_RPM), _UNIT_RANGE),
    "tyres": ((0.0, FLOAT_LIMIT), _UNIT_RANGE),
    "siren": ((0.0, len(SIREN_PATTERNS) - 1), (0.0, 0.0)),
}


def _check_drive(e: AudioEmitter) -> None:
    """Each kind's drive values in their documented range (the renderer relies on it)."""
    ranges = _DRIVE_RANGES.get(e.kind, (_UNIT_RANGE, (0.0, 0.0)))
    for name, value, (low, high) in (("drive_a", e.drive_a, ranges[0]),
                                     ("drive_b", e.drive_b, ranges[1])):  # fmt: skip
        if not low <= value <= high:
            raise MessageError(f"audio emitter {e.id!r} ({e.kind}): {name} = {value!r} "
                               f"is outside [{low:g}, {high:g}]")  # fmt: skip
    if e.kind == "siren" and e.drive_a != int(e.drive_a):
        raise MessageError(f"audio emitter {e.id!r}: siren pattern {e.drive_a!r} is not an index")


# --------------------------------------------------------------------------- queries


class Extent(msgspec.Struct, frozen=True, array_like=True):
    length: Finite = 4.5  # [m]
    width: Finite = 1.8  # [m]
    height: Finite = 1.5  # [m]


# Typical extents per actor kind [m], for an actor whose own extent is not known.
KIND_EXTENTS: dict[str, Extent] = {
    "car": Extent(4.5, 1.8, 1.5),
    "van": Extent(5.2, 2.0, 2.3),
    "truck": Extent(9.0, 2.5, 3.4),
    "bus": Extent(12.0, 2.55, 3.1),
    "motorcycle": Extent(2.1, 0.8, 1.5),
    "bicycle": Extent(1.8, 0.6, 1.7),
    "pedestrian": Extent(0.5, 0.6, 1.75),
    "other": Extent(4.0, 1.8, 1.6),
}


class SpawnPoint(msgspec.Struct, frozen=True, array_like=True):
    x: Finite
    y: Finite
    z: Finite = 0.0
    yaw: Finite = 0.0


class JoinRequest(msgspec.Struct, frozen=True):
    schema: Int64
    node_id: str
    instance: str  # random per process run: tells a re-join from a duplicate id
    kind: str  # node kind: drive, bike, walk, scripted, observer ...
    actor_kind: str = "car"  # one of ACTOR_KINDS; observers have no actor
    extent: Extent = Extent()
    mass_kg: Finite = 1500.0
    site: str = ""
    hostname: str = ""
    version: str = ""
    pose_rate_hz: Finite = 50.0
    config_yaml: str = ""  # the node's effective config, archived with recordings


class JoinReply(msgspec.Struct, frozen=True):
    schema: Int64
    accepted: bool
    reason: str = ""
    session: str = ""
    spawn: SpawnPoint | None = None
    despawn_timeout_s: Finite = 3.0
    tick_hz: Finite = 50.0
    authority_instance: str = ""
    # [s] how often the authority relays the pose digest (`world/@egos`); 0: it relays none
    pose_digest_s: Finite = 0.0


class LeaveRequest(msgspec.Struct, frozen=True):
    """A node leaving on purpose, sent on `authority/leave` before it drops its token.

    `instance` must be the one the node joined with: only the joined process can make its id
    leave (the instance travels nowhere but in its own join request).
    """

    node_id: str
    instance: str


class LeaveReply(msgspec.Struct, frozen=True):
    left: bool  # False: the authority did not know this node (already gone, or not it)


class ClockRequest(msgspec.Struct, frozen=True):
    node_id: str = ""


class ClockReply(msgspec.Struct, frozen=True, array_like=True):
    t: Time  # [s] session time when the authority answered
    known: bool = False  # whether the asking node is currently joined


class EgoInfo(msgspec.Struct, frozen=True):
    """One joined node as the snapshot lists it.

    The pose travels in the one pose layout (`POSE_LAYOUT`, 64 bytes) under the wire name
    `pose`; `pose_wire` holds those bytes and `.pose` decodes them. For convenience a `Pose` may
    be passed where the bytes go; it is encoded on construction.
    """

    node_id: str
    kind: str
    actor_kind: str
    extent: Extent
    mass_kg: Finite
    site: str = ""
    pose_wire: bytes | None = msgspec.field(default=None, name="pose")
    state: EgoState | None = None

    def __post_init__(self) -> None:
        if isinstance(self.pose_wire, Pose):
            msgspec.structs.force_setattr(self, "pose_wire", encode_pose(self.pose_wire))
        elif self.pose_wire is not None:
            decode_pose(self.pose_wire)  # refuse a bad layout at decode time, with the reason

    @property
    def pose(self) -> Pose | None:
        return None if self.pose_wire is None else decode_pose(self.pose_wire)


class Snapshot(msgspec.Struct, frozen=True):
    schema: Int64
    t: Time
    egos: list[EgoInfo]
    npc: NpcBatch | None = None
    lights: LightsState | None = None
    weather: Weather | None = None


class MapLane(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # road | sidewalk | bike | crossing | walkingarea | rail
    width: Finite  # [m]
    centerline: list[tuple[Finite, Finite]]  # [m]
    allow: list[str] = []
    speed: Finite = 0.0  # [m/s] its speed limit (SUMO lane speed); 0 when not known
    change_left: bool = True  # a car may change from it to the lane on its left (changeLeft)
    change_right: bool = True  # a car may change from it to the lane on its right (changeRight)
    opposite: str = ""  # the oncoming lane beyond its left edge that may be used to overtake
    # What rules a vehicle at the lane's end, from SUMO's junction type and link states: signal |
    # major | yield | stop | allway_stop | right_before_left | left_before_right | zipper, or ""
    # for nothing (a dead end, a pedestrian lane); a receiver reads a word it does not know as "".
    right_of_way: str = ""  # what rules a vehicle at its end (Map lane rules, below)
    successors: list[str] = []  # the lanes its connections lead to, beyond the junction


class MapArea(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # junction | vegetation | water | building
    polygon: list[tuple[Finite, Finite]]


class MapLight(msgspec.Struct, frozen=True, array_like=True):
    id: str  # traffic light (SUMO tls) id
    position: tuple[Finite, Finite]
    controlled_lanes: list[str]  # one entry per link index of the light's state string


class MapReply(msgspec.Struct, frozen=True):
    schema: Int64
    name: str
    bounds: tuple[Finite, Finite, Finite, Finite]  # xmin, ymin, xmax, ymax [m]
    lanes: list[MapLane]
    areas: list[MapArea] = []
    lights: list[MapLight] = []


class ScenarioReply(msgspec.Struct, frozen=True):
    schema: Int64
    name: str
    yaml: str  # the scenario file as run, byte-for-byte
    seed: Int64 = 0


class ConfigsReply(msgspec.Struct, frozen=True):
    """Every joined node's effective config, for archiving with a recording."""

    schema: Int64
    nodes: dict[str, str]  # node id -> config YAML as the node sent it at join
    scenario_yaml: str = ""
    hostnames: dict[str, str] = {}  # node id -> host it joined from


# --------------------------------------------------------------------------- codecs


class Codec(Generic[T]):
    """Encoder and decoder for one message type, built once.

    `check` validates what the type system cannot say (a byte blob's length, the values packed
    in it); it runs on every decode and raises MessageError.
    """

    def __init__(self, type_: Any, check: Callable[[Any], None] | None = None) -> None:
        self.type = type_
        self._check = check
        self._encoder = msgspec.msgpack.Encoder()
        self._decoder = msgspec.msgpack.Decoder(type_)

    def encode(self, msg: T) -> bytes:
        try:
            return self._encoder.encode(msg)
        except Exception as exc:  # OverflowError, UnicodeEncodeError, TypeError: all one case
            raise MessageError(f"{_type_name(self.type)} cannot be encoded: {exc}") from exc

    def decode(self, buf: bytes | bytearray | memoryview) -> T:
        try:
            message = self._decoder.decode(buf)
            if self._check is not None:
                self._check(message)
            return message
        except MessageError:
            raise
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise MessageError(f"{_type_name(self.type)}: {exc}") from exc
        # Untrusted bytes can make msgspec raise more than its own errors (RecursionError on
        # deep nesting, UnicodeDecodeError, MemoryError on absurd lengths): to every caller
        # they are one thing, a payload that is not this message.
        except Exception as exc:
            raise MessageError(f"{_type_name(self.type)}: {type(exc).__name__}: {exc}") from exc


class PoseCodec(Codec[Pose]):
    def __init__(self) -> None:
        self.type = Pose

    def encode(self, msg: Pose) -> bytes:
        return encode_pose(msg)

    def decode(self, buf: bytes | bytearray | memoryview) -> Pose:
        try:
            return decode_pose(buf)
        except MessageError:
            raise
        except Exception as exc:  # e.g. a buffer-protocol object that is not bytes
            raise MessageError(f"pose: {type(exc).__name__}: {exc}") from exc


def _type_name(type_: Any) -> str:
    return getattr(type_, "__name__", None) or str(type_)


POSE = PoseCodec()
EGO_STATE: Codec[EgoState] = Codec(EgoState)
OVERRIDE: Codec[Override] = Codec(Override)
SKELETON: Codec[Skeleton] = Codec(Skeleton, _check_skeleton)
NPC_BATCH: Codec[NpcBatch] = Codec(NpcBatch, _check_npc_batch)
POSE_DIGEST: Codec[PoseDigest] = Codec(PoseDigest, _check_pose_digest)
LIGHTS: Codec[LightsState] = Codec(LightsState)
WEATHER: Codec[Weather] = Codec(Weather)
WORLD_EVENT: Codec[WorldEvent] = Codec(WorldEvent)
IMPULSE: Codec[Impulse] = Codec(Impulse)
AUDIO_SCENE: Codec[AudioScene] = Codec(AudioScene, _check_audio_scene)
JOIN_REQUEST: Codec[JoinRequest] = Codec(JoinRequest)
JOIN_REPLY: Codec[JoinReply] = Codec(JoinReply)
LEAVE_REQUEST: Codec[LeaveRequest] = Codec(LeaveRequest)
LEAVE_REPLY: Codec[LeaveReply] = Codec(LeaveReply)
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
    ("world", DIGEST_CHANNEL): POSE_DIGEST,
    ("world", "lights"): LIGHTS,
    ("world", "weather"): WEATHER,
    ("world", "events"): WORLD_EVENT,
    ("impulse", ""): IMPULSE,
    ("audio", ""): AUDIO_SCENE,
    ("authority", "join"): JOIN_REPLY,
    ("authority", "leave"): LEAVE_REPLY,
    ("authority", "clock"): CLOCK_REPLY,
    ("authority", "snapshot"): SNAPSHOT,
    ("authority", "map"): MAP,
    ("authority", "scenario"): SCENARIO,
    ("authority", "configs"): CONFIGS,
}

# What the authority's queryables expect as the query payload (the requests).
REQUEST_CODECS: dict[str, Codec[Any]] = {
    "join": JOIN_REQUEST,
    "leave": LEAVE_REQUEST,
    "clock": CLOCK_REQUEST,
}


# --------------------------------------------------------------------------- study: questionnaires
# Issue 44. Between trials the study runner asks a participant's node to show a questionnaire
# on the participant's own screen, the node's web HMI (`study/<id>/ask`). The node answers on
# `study/<id>/answers` with every answer given so far, each time one changes, and once more with
# `final` set when the participant submits. Each answers message holds the whole set so far, so
# the newest is the partial set when a node goes away mid-way. The runner repeats its request
# until the final set comes; a node that sent it already sends it again, so no single lost
# message loses answers. Answers are checked against the request they answer
# (carlaverse.study.questionnaires): an unknown item, a value off the scale or too long a text
# is counted and dropped by the runner.

QUESTIONNAIRE_MAX_ITEMS = 64
QUESTIONNAIRE_MAX_POINTS = 101  # values of a scale, options of a choice
QUESTIONNAIRE_MAX_TEXT = 2000  # [characters] of a free-text answer or of instructions
StudyId = Annotated[str, msgspec.Meta(pattern=anchored(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,62}"))]
ShortText = Annotated[str, msgspec.Meta(max_length=500)]
LongText = Annotated[str, msgspec.Meta(max_length=QUESTIONNAIRE_MAX_TEXT)]
ScaleValue = Annotated[int, msgspec.Meta(ge=-1000, le=1000)]


class QuestionnaireItem(msgspec.Struct, frozen=True):
    """One question as a participant's page shows it."""

    id: StudyId
    text: ShortText
    kind: Literal["scale", "choice", "text"]
    low: ScaleValue = 0  # scale: the lowest value
    high: ScaleValue = 0  # scale: the highest value
    step: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 1  # scale: between neighbouring values
    # scale: the two ends' anchors, or one per value; choice: the options (answer: the index)
    labels: Annotated[list[ShortText], msgspec.Meta(max_length=QUESTIONNAIRE_MAX_POINTS)] = []
    required: bool = True  # the page submits only when it is answered
    max_chars: Annotated[int, msgspec.Meta(ge=1, le=QUESTIONNAIRE_MAX_TEXT)] = 500  # text

    def __post_init__(self) -> None:  # msgspec turns this ValueError into its decode error
        problem = _item_problem(self)
        if problem:
            raise ValueError(f"item {self.id!r}: {problem}")

    def points(self) -> int:
        """How many values a scale has, or options a choice; 0 for text."""
        if self.kind == "scale":
            return (self.high - self.low) // self.step + 1
        return len(self.labels) if self.kind == "choice" else 0


def _item_problem(item: QuestionnaireItem) -> str:
    """What makes an item unshowable, or ""."""
    points = item.points()
    if item.kind == "scale" and not (
        item.high > item.low and (item.high - item.low) % item.step == 0
    ):
        return "a scale needs high > low, in whole steps"
    if item.kind == "scale" and points > QUESTIONNAIRE_MAX_POINTS:
        return f"a scale has at most {QUESTIONNAIRE_MAX_POINTS} values"
    if item.kind == "scale" and len(item.labels) not in (0, 2, points):
        return f"a scale's labels: none, the two ends, or one per value ({points})"
    if item.kind == "choice" and len(item.labels) < 2:
        return "a choice needs two options or more in labels"
    return ""


class QuestionnaireRequest(msgspec.Struct, frozen=True):
    """A questionnaire for a participant's HMI, from the study runner."""

    schema: Int64
    request_id: StudyId  # one per showing (e.g. "<trial>.<questionnaire>"); answers name it
    trial: StudyId
    questionnaire: StudyId  # e.g. "ssq", "nasa-tlx"
    title: ShortText
    items: Annotated[
        list[QuestionnaireItem], msgspec.Meta(min_length=1, max_length=QUESTIONNAIRE_MAX_ITEMS)
    ]
    instructions: LongText = ""


class QuestionnaireAnswers(msgspec.Struct, frozen=True):
    """A participant's answers so far to one QuestionnaireRequest, from the node."""

    schema: Int64
    request_id: StudyId
    node_id: StudyId
    seq: Seq  # counts the sets the node sent for this request
    # item id -> scale value, choice index or text
    answers: Annotated[
        dict[StudyId, ScaleValue | LongText], msgspec.Meta(max_length=QUESTIONNAIRE_MAX_ITEMS)
    ]
    final: bool = False  # the participant submitted: the set is complete


QUESTIONNAIRE_REQUEST: Codec[QuestionnaireRequest] = Codec(QuestionnaireRequest)
QUESTIONNAIRE_ANSWERS: Codec[QuestionnaireAnswers] = Codec(QuestionnaireAnswers)
CHANNEL_CODECS[("study", "ask")] = QUESTIONNAIRE_REQUEST
CHANNEL_CODECS[("study", "answers")] = QUESTIONNAIRE_ANSWERS


# --------------------------------------------------------------------------- study: trials
# Issue 44. A study's runner briefs each participant's agent (`carlaverse study agent`, on the
# participant's machine) on `carlaverse/<study>/study/<participant>/brief`, the study's name
# standing as the session: the trial to take part in now, or none. The brief is put again
# every half second, so an agent that starts or reconnects late hears it; the agent starts the
# participant's node in the trial's session with the brief's node config, and stops it when a
# brief names another trial or none.

STUDY_BRIEF_MAX_CONFIG = 65536  # [characters] of a node config in a brief


class TrialBrief(msgspec.Struct, frozen=True):
    """What a study's runner tells one participant's agent, repeated while it holds."""

    schema: Int64
    study: StudyId
    participant: StudyId
    active: bool = False  # False between trials: the agent stops the node
    trial: StudyId = "none"
    attempt: Seq = 0  # a redone trial is a new attempt: a new node in a new session
    session: StudyId = "none"  # the trial's session, where the node joins
    kind: Literal["drive", "bike", "walk", "scripted", "observer"] = "observer"
    condition: StudyId = "none"
    duration_s: Annotated[float, msgspec.Meta(ge=0, le=86400)] = 0.0  # [s] 0: until told
    # the node's config with the condition's overrides merged in (YAML); "" for the kind's own
    node_config_yaml: Annotated[str, msgspec.Meta(max_length=STUDY_BRIEF_MAX_CONFIG)] = ""
    backend: Annotated[str, msgspec.Meta(max_length=32)] = ""  # "sim": devices simulated
    # the participant's link in this trial, as the runner applies it (for the record)
    delay_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0
    jitter_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0
    loss: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.0


TRIAL_BRIEF: Codec[TrialBrief] = Codec(TrialBrief)
CHANNEL_CODECS[("study", "brief")] = TRIAL_BRIEF
