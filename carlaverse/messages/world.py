"""The world the authority publishes besides the egos: NPC batches, traffic lights, weather."""

from __future__ import annotations

import msgspec
import numpy as np

from carlaverse.messages.base import Finite, Int64, MessageError, Seq, Time
from carlaverse.messages.codec import Codec

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


NPC_BATCH: Codec[NpcBatch] = Codec(NpcBatch, _check_npc_batch)
LIGHTS: Codec[LightsState] = Codec(LightsState)
WEATHER: Codec[Weather] = Codec(Weather)
