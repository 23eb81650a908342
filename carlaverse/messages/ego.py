"""An ego's state beside its pose: lights and gear on change, an ADAS override, a walker's
skeleton."""

from __future__ import annotations

from typing import Literal

import msgspec

from carlaverse.messages.base import Finite, Int64, MessageError, Seq, Time
from carlaverse.messages.codec import Codec

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


EGO_STATE: Codec[EgoState] = Codec(EgoState)
OVERRIDE: Codec[Override] = Codec(Override)
SKELETON: Codec[Skeleton] = Codec(Skeleton, _check_skeleton)
