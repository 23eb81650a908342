"""The collision matrix: which actors touch, since when, and the impulse a new contact gives.

Each tick every actor (egos dead-reckoned to the tick, NPCs) goes through the broadphase and
the oriented-box narrowphase (`obb`). Contacts are tracked across ticks by the pair of actor
keys, so one touch gives one impulse at its start and one `ContactEnded` when the boxes part,
however many ticks it lasts.

The impulse of a new contact along the normal n (unit, from the other actor into this one):

    J = −(1 + e) · (v_rel · n) / (1/m₁ + 1/m₂),   v_rel = v_this − v_other

applied as J·n to this actor and −J·n to the other (zero when the pair is already
separating). e is the mean of the two actors' restitution; masses and restitution come per
actor kind from the scenario, an ego's mass from its join. Ego–ego contacts therefore give
equal and opposite impulses by construction.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from carlaverse.authority.obb import (
    aabb_half_extents,
    box_overlaps,
    corners,
    intersection_centroid,
    sweep_and_prune,
)
from carlaverse.messages import ACTOR_KINDS, ContactEnded, ContactStarted, Impulse

ActorKey = tuple[bool, str]  # (is an ego, id): egos and NPCs may share a name
PairKey = tuple[ActorKey, ActorKey]  # canonical order: the smaller key first
Touch = tuple[int, int, np.ndarray]  # actor indices, unit normal from the second into the first


@dataclass(slots=True)
class Actors:
    """Every actor of one tick as columns (centre poses, box half sizes, velocities)."""

    ids: list[str]
    kind: np.ndarray  # messages.ACTOR_KINDS index per actor
    is_ego: np.ndarray  # bool
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    z: np.ndarray  # [m] bottom of the box
    yaw: np.ndarray  # [rad]
    hl: np.ndarray  # [m] half length
    hw: np.ndarray  # [m] half width
    h: np.ndarray  # [m] height
    vx: np.ndarray  # [m/s]
    vy: np.ndarray  # [m/s]
    mass: np.ndarray  # [kg]
    restitution: np.ndarray  # 0..1

    def key(self, i: int) -> ActorKey:
        return (bool(self.is_ego[i]), self.ids[i])

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(slots=True)
class Contact:
    contact_id: int
    a: ActorKey
    b: ActorKey


@dataclass(slots=True)
class TickContacts:
    """What one tick of the matrix decided."""

    events: list[ContactStarted | ContactEnded] = field(default_factory=list)
    impulses: list[tuple[str, Impulse]] = field(default_factory=list)  # (ego node id, impulse)
    hit_npcs: list[str] = field(default_factory=list)  # NPCs an ego just ran into


class CollisionMatrix:
    """Contacts between actors, tracked across ticks."""

    def __init__(self, npc_npc: bool = False) -> None:
        self._npc_npc = npc_npc
        self._contacts: dict[PairKey, Contact] = {}
        self._ids = itertools.count(1)

    @property
    def active(self) -> list[Contact]:
        return list(self._contacts.values())

    def step(self, t: float, actors: Actors, next_seq: Callable[[], int]) -> TickContacts:
        """Find this tick's contacts; report those that started and those that ended."""
        out = TickContacts()
        touching = self._touching(actors)
        for pair in [p for p in self._contacts if p not in touching]:
            c = self._contacts.pop(pair)
            out.events.append(ContactEnded(next_seq(), t, c.contact_id, c.a[1], c.b[1]))
        for pair, touch in touching.items():
            if pair not in self._contacts:
                self._start(t, actors, touch, next_seq, out)
        return out

    def _touching(self, actors: Actors) -> dict[PairKey, Touch]:
        """Overlapping pairs, keyed in a canonical order, with the normal into the first."""
        if len(actors) < 2:
            return {}
        ex, ey = aabb_half_extents(actors.hl, actors.hw, actors.yaw)
        i, j = sweep_and_prune(actors.x - ex, actors.x + ex, actors.y - ey, actors.y + ey)
        if not self._npc_npc:
            keep = actors.is_ego[i] | actors.is_ego[j]
            i, j = i[keep], j[keep]
        if len(i) == 0:
            return {}
        a = actors
        o = box_overlaps(i, j, a.x, a.y, a.yaw, a.hl, a.hw, a.z, a.h)
        found = {}
        for k in np.flatnonzero(o.hit):
            first, second, n = int(i[k]), int(j[k]), o.normal[k]
            if a.key(second) < a.key(first):
                first, second, n = second, first, -n
            found[(a.key(first), a.key(second))] = (first, second, n)
        return found

    def _start(self, t: float, actors: Actors, touch: Touch, next_seq: Callable[[], int],
               out: TickContacts) -> None:  # fmt: skip
        i, j, normal = touch
        contact = Contact(next(self._ids), actors.key(i), actors.key(j))
        self._contacts[(contact.a, contact.b)] = contact
        rel = np.array([actors.vx[i] - actors.vx[j], actors.vy[i] - actors.vy[j]])  # [m/s]
        speed = float(math.hypot(*rel))
        out.events.append(ContactStarted(next_seq(), t, contact.contact_id, actors.ids[i],
                                         actors.ids[j], speed))  # fmt: skip
        e = (actors.restitution[i] + actors.restitution[j]) / 2
        magnitude = impulse_magnitude(rel, normal, actors.mass[i], actors.mass[j], e)
        point = _contact_point(actors, i, j)
        for this, other, n in ((i, j, normal), (j, i, -normal)):
            if actors.is_ego[this]:
                impulse = (float(magnitude * n[0]), float(magnitude * n[1]), 0.0)  # [N·s]
                out.impulses.append((actors.ids[this], Impulse(
                    next_seq(), t, contact.contact_id, impulse, point,
                    (float(n[0]), float(n[1]), 0.0), actors.ids[other],
                    ACTOR_KINDS[actors.kind[other]], speed,
                )))  # fmt: skip
            elif actors.is_ego[other]:
                out.hit_npcs.append(actors.ids[this])


def impulse_magnitude(rel: np.ndarray, normal: np.ndarray, m1: float, m2: float, e: float) -> float:
    """J = −(1+e)(v_rel·n)/(1/m₁+1/m₂) [N·s], zero when the bodies already separate."""
    closing = float(rel @ normal)
    if closing >= 0.0:
        return 0.0
    return -(1.0 + e) * closing / (1.0 / m1 + 1.0 / m2)


def _contact_point(actors: Actors, i: int, j: int) -> tuple[float, float, float]:
    p = corners(actors.x[i], actors.y[i], actors.yaw[i], actors.hl[i], actors.hw[i])
    q = corners(actors.x[j], actors.y[j], actors.yaw[j], actors.hl[j], actors.hw[j])
    cx, cy = intersection_centroid(p, q)
    bottom = max(actors.z[i], actors.z[j])
    top = min(actors.z[i] + actors.h[i], actors.z[j] + actors.h[j])
    return (float(cx), float(cy), float((bottom + top) / 2))
