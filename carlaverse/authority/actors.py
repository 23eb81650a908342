"""The actors of one tick: egos dead-reckoned to the tick time, and the engine's NPCs.

All egos are moved at once, as columns (`EgoColumns`): the tick's work per ego is a few array
operations, not a Python object per ego and stage.

An ego's latest pose sample was taken at `pose.t`, a little before the tick; it is moved on
to the tick time by the one motion model (`carlaverse.dead_reckoning`: velocity turning at the
yaw rate, acceleration; at most `max_extrapolation_s`, then held), so the collision matrix and
the traffic engine see where the human is now, and where every node's view draws them.
"""

from __future__ import annotations

import itertools
import math
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from msgspec.structs import astuple

from carlaverse.authority.collisions import Actors
from carlaverse.authority.domain import EgoTrack
from carlaverse.dead_reckoning import Motion, project_many
from carlaverse.messages import ACTOR_KINDS, Extent, Pose
from carlaverse.traffic.engine import EgoPlacement, EgoPlacements, NpcFrame, kind_code
from carlaverse.traffic.scenario import CollisionSpec

NO_ACTOR_KINDS = {"observer"}  # node kinds that join without a body in the world


@dataclass(frozen=True, slots=True)
class EgoNow:
    """One ego at the tick time (centre pose, world frame)."""

    node_id: str
    actor_kind: str
    x: float  # [m]
    y: float  # [m]
    z: float  # [m]
    yaw: float  # [rad]
    vx: float  # [m/s]
    vy: float  # [m/s]
    length: float  # [m]
    width: float  # [m]
    height: float  # [m]
    mass_kg: float  # [kg], 0 = use the kind's mass

    def placement(self) -> EgoPlacement:
        speed = self.vx * math.cos(self.yaw) + self.vy * math.sin(self.yaw)
        return EgoPlacement(
            self.node_id,
            self.actor_kind,
            self.x,
            self.y,
            self.z,
            self.yaw,
            speed,
            self.length,
            self.width,
            self.height,
        )


EGO_COLUMNS = ("x", "y", "z", "yaw", "vx", "vy", "length", "width", "height", "mass_kg")


@dataclass(frozen=True, slots=True)
class EgoColumns(Sequence[EgoNow]):
    """The egos of one tick as columns, one entry per ego (the fields of `EgoNow`).

    Reads as a sequence of `EgoNow` where one ego at a time is wanted (triggers, tests); the
    per-tick work over all egos (placements, the collision matrix, audio) uses the columns.
    """

    ids: list[str]
    actor_kinds: list[str]
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    z: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s]
    vy: np.ndarray  # [m/s]
    length: np.ndarray  # [m]
    width: np.ndarray  # [m]
    height: np.ndarray  # [m]
    mass_kg: np.ndarray  # [kg], 0 = use the kind's mass
    _kind_codes: np.ndarray | None = field(default=None, compare=False, repr=False)

    @classmethod
    def of(cls, egos: Sequence[EgoNow]) -> EgoColumns:
        """Columns of a list of egos (or the columns themselves)."""
        if isinstance(egos, EgoColumns):
            return egos
        values = np.array([[getattr(e, f) for f in EGO_COLUMNS] for e in egos], dtype=np.float64)
        values = values.reshape(len(egos), len(EGO_COLUMNS))
        return cls([e.node_id for e in egos], [e.actor_kind for e in egos], *values.T)

    def __len__(self) -> int:
        return len(self.ids)

    def __getitem__(self, i: int) -> EgoNow:  # type: ignore[override]
        if not -len(self.ids) <= i < len(self.ids):
            raise IndexError(f"ego {i} of {len(self.ids)}")
        values = (float(getattr(self, f)[i]) for f in EGO_COLUMNS)
        return EgoNow(self.ids[i], self.actor_kinds[i], *values)

    def kind_codes(self) -> np.ndarray:
        # Asked by the collision matrix and the audio every tick: computed once per tick.
        codes = self._kind_codes
        if codes is None:
            codes = np.array([kind_code(k) for k in self.actor_kinds], dtype=np.intp)
            object.__setattr__(self, "_kind_codes", codes)
        return codes

    def placements(self) -> EgoPlacements:
        """Where the engine carries each ego: `EgoNow.placement` for all at once."""
        speed = self.vx * np.cos(self.yaw) + self.vy * np.sin(self.yaw)  # [m/s] along heading
        columns = (self.x, self.y, self.z, self.yaw, speed, self.length, self.width, self.height)
        table = np.column_stack(columns).reshape(len(self.ids), len(columns))
        return EgoPlacements(self.ids, self.actor_kinds, table)


# A pose as a row of doubles, its fields in order (seq, t, x, y, z, roll, pitch, yaw, vx, vy,
# vz, wx, wy, wz, ax, ay, az, flags); where `t` and the `Motion` fields lie in it.
_POSE_ROW = struct.Struct(f"<{len(Pose.__struct_fields__)}d")
_EXTENT_ROW = struct.Struct(f"<{len(Extent.__struct_fields__)}d")  # length, width, height
_T = Pose.__struct_fields__.index("t")
_MOTION = [Pose.__struct_fields__.index(f) for f in Motion._fields]


def has_actor(track: EgoTrack) -> bool:
    return track.info.kind not in NO_ACTOR_KINDS and track.info.actor_kind in ACTOR_KINDS


def egos_at(t: float, egos: Mapping[str, EgoTrack], max_extrapolation_s: float) -> EgoColumns:
    """Every embodied ego with a pose, dead-reckoned to `t` by the one motion model
    (`carlaverse.dead_reckoning`, as every node's world view draws it), in node-id order."""
    chosen = [k for n in sorted(egos) if (k := egos[n]).last_pose is not None and has_actor(k)]
    infos = [k.info for k in chosen]
    # Every field of every pose, and every extent, packed by `struct` in C: a third faster
    # than `np.fromiter` over the same floats (a few hundred egos every tick).
    poses = [p for k in chosen if (p := k.last_pose) is not None]  # all of them: typed so
    rows = b"".join(itertools.starmap(_POSE_ROW.pack, map(astuple, poses)))
    c = np.frombuffer(rows).reshape(len(chosen), len(Pose.__struct_fields__)).T
    extents = b"".join(itertools.starmap(_EXTENT_ROW.pack, map(astuple, [i.extent for i in infos])))
    dt = np.minimum(np.maximum(t - c[_T], 0.0), max_extrapolation_s)  # [s]
    now = project_many(Motion(*c[_MOTION]), dt)  # one copy of the columns it reads
    length, width, height = np.frombuffer(extents).reshape(len(infos), 3).T
    return EgoColumns(
        [i.node_id for i in infos],
        [i.actor_kind for i in infos],
        now.x,
        now.y,
        now.z,
        now.yaw,
        now.vx,
        now.vy,
        length,
        width,
        height,
        np.fromiter([i.mass_kg for i in infos], np.float64, len(infos)),
    )


def build_actors(egos: Sequence[EgoNow], frame: NpcFrame, spec: CollisionSpec) -> Actors:
    """Egos first, then NPCs, as the columns the collision matrix works on."""
    e = EgoColumns.of(egos)
    rows = frame.rows
    mass_of = np.array([spec.physics(k).mass_kg for k in ACTOR_KINDS])  # [kg] by kind code
    bounce_of = np.array([spec.physics(k).restitution for k in ACTOR_KINDS])
    ego_kind = e.kind_codes()
    kind = np.concatenate([ego_kind, rows["kind"].astype(np.intp)])
    ego_mass = np.where(e.mass_kg > 0, e.mass_kg, mass_of[ego_kind])

    def column(ego: np.ndarray, npc: str) -> np.ndarray:
        return np.concatenate([ego, rows[npc].astype(np.float64)])

    return Actors(
        ids=e.ids + frame.ids,
        kind=kind,
        is_ego=np.arange(len(kind)) < len(e),
        x=column(e.x, "x"),
        y=column(e.y, "y"),
        z=column(e.z, "z"),
        yaw=column(e.yaw, "yaw"),
        hl=column(e.length, "length") / 2,
        hw=column(e.width, "width") / 2,
        h=column(e.height, "height"),
        vx=column(e.vx, "vx"),
        vy=column(e.vy, "vy"),
        mass=np.concatenate([ego_mass, mass_of[kind[len(e) :]]]),
        restitution=bounce_of[kind],
    )
