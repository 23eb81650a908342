"""The actors of one tick: egos dead-reckoned to the tick time, and the engine's NPCs.

An ego's latest pose sample was taken at `pose.t`, a little before the tick; it is moved on
by its velocity and yaw rate to the tick time (at most `max_extrapolation_s`, then held), so
the collision matrix and the traffic engine see where the human is now, not where they were.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from carlaverse.authority.collisions import Actors
from carlaverse.authority.domain import EgoTrack
from carlaverse.messages import ACTOR_KINDS
from carlaverse.traffic.engine import EgoPlacement, NpcFrame, kind_code
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


def has_actor(track: EgoTrack) -> bool:
    return track.info.kind not in NO_ACTOR_KINDS and track.info.actor_kind in ACTOR_KINDS


def egos_at(t: float, egos: Mapping[str, EgoTrack], max_extrapolation_s: float) -> list[EgoNow]:
    """Every embodied ego with a pose, dead-reckoned to `t`, in node-id order."""
    out = []
    for node_id in sorted(egos):
        track = egos[node_id]
        pose = track.last_pose
        if pose is None or not has_actor(track):
            continue
        dt = min(max(t - pose.t, 0.0), max_extrapolation_s)  # [s]
        e = track.info.extent
        out.append(
            EgoNow(
                node_id,
                track.info.actor_kind,
                pose.x + pose.vx * dt,
                pose.y + pose.vy * dt,
                pose.z + pose.vz * dt,
                pose.yaw + pose.wz * dt,
                pose.vx,
                pose.vy,
                e.length,
                e.width,
                e.height,
                track.info.mass_kg,
            )
        )
    return out


def build_actors(egos: list[EgoNow], frame: NpcFrame, spec: CollisionSpec) -> Actors:
    """Egos first, then NPCs, as the columns the collision matrix works on."""
    rows = frame.rows
    mass_of = np.array([spec.physics(k).mass_kg for k in ACTOR_KINDS])  # [kg] by kind code
    bounce_of = np.array([spec.physics(k).restitution for k in ACTOR_KINDS])
    ego_kind = np.array([kind_code(e.actor_kind) for e in egos], dtype=np.intp)
    kind = np.concatenate([ego_kind, rows["kind"].astype(np.intp)])
    ego_mass = np.array([e.mass_kg for e in egos], dtype=np.float64)
    ego_mass = np.where(ego_mass > 0, ego_mass, mass_of[ego_kind])

    def column(attr: str, npc: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [np.array([getattr(e, attr) for e in egos], dtype=np.float64), npc.astype(np.float64)]
        )

    return Actors(
        ids=[e.node_id for e in egos] + frame.ids,
        kind=kind,
        is_ego=np.arange(len(kind)) < len(egos),
        x=column("x", rows["x"]),
        y=column("y", rows["y"]),
        z=column("z", rows["z"]),
        yaw=column("yaw", rows["yaw"]),
        hl=column("length", rows["length"]) / 2,
        hw=column("width", rows["width"]) / 2,
        h=column("height", rows["height"]),
        vx=column("vx", rows["vx"]),
        vy=column("vy", rows["vy"]),
        mass=np.concatenate([ego_mass, mass_of[kind[len(egos) :]]]),
        restitution=bounce_of[kind],
    )
