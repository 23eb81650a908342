"""The pose: an ego's telemetry sample, in its fixed 64-byte little-endian layout
(`POSE_LAYOUT`) rather than MessagePack, because msgspec writes every float as 8 bytes and the
pose is the hottest message of all."""

from __future__ import annotations

import math
import struct

import msgspec

from carlaverse.messages.base import TIME_LIMIT_S, MessageError
from carlaverse.messages.codec import Codec

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


def pose_or_refusal(buf: bytes | bytearray | memoryview) -> Pose | str:
    """The wire pose decoded once the receiver's checks pass (layout, every value finite, the
    time in range), else the reason it is refused, in words. One frame for the whole check:
    a node's loop decodes each pose it hears here, with the caches cold after its sleep."""
    if len(buf) != POSE_SIZE:
        return f"pose: expected {POSE_SIZE} bytes, got {len(buf)}"
    v = POSE_LAYOUT.unpack(buf)
    if v[0] != POSE_LAYOUT_VERSION:
        return f"pose: unknown layout version {v[0]}"
    # One sum instead of 18 checks: a NaN or an infinity in any field makes it non-finite,
    # and finite fields cannot overflow it (f32/f16 ranges; an absurd time is refused anyway).
    if not math.isfinite(sum(v[4:])):
        return "pose: non-finite value"
    if abs(v[4]) > TIME_LIMIT_S:
        return f"pose: time {v[4]!r} s is out of range"
    # The layout unpacks into exactly Pose's positional fields after `seq`, so `flags` is never
    # filled twice; mypy cannot count a slice of the unpacked tuple.
    return Pose(v[3], *v[4:], flags=v[1])  # type: ignore[misc]


def decode_pose(buf: bytes | bytearray | memoryview) -> Pose:
    """The wire pose; MessageError naming what failed its checks (`pose_or_refusal`)."""
    pose = pose_or_refusal(buf)
    if isinstance(pose, str):
        raise MessageError(pose)
    return pose


_POSE_STAMP = struct.Struct("<4xId")  # seq u32 at byte 4, t f64 at byte 8 (POSE_LAYOUT)


def pose_stamp(buf: bytes | bytearray | memoryview) -> tuple[int, float]:
    """The sequence number and time of a wire pose, read without decoding the rest."""
    seq, t = _POSE_STAMP.unpack_from(buf)
    return seq, t


class PoseCodec(Codec[Pose]):
    """The pose's codec: its fixed 64-byte layout instead of MessagePack."""

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


POSE = PoseCodec()
