"""The sound sources on actors at one instant: engines, tyres and sirens, as columns.

Sources ride on NPCs and on the humans' actors alike (a listener hears another driver's car
like any other); each carries its owner, so no listener is sent its own engine (its node
renders that from its own powertrain). Acceleration, which sets an engine's load, is the
change of speed since the previous audio instant, per actor id.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import chain

import numpy as np

from carlaverse.authority.actors import EgoColumns, EgoNow
from carlaverse.authority.sound_models import MIN_ROLLING_MPS, EngineBank, TyreBank
from carlaverse.messages import AUDIO_KINDS, SIREN_PATTERNS
from carlaverse.traffic.engine import NpcFrame
from carlaverse.traffic.soundscape import SirenSpec

KIND_INDEX = {kind: i for i, kind in enumerate(AUDIO_KINDS)}


@dataclass(frozen=True, slots=True)
class ActorColumns:
    """Every actor (egos, then NPCs) at one instant."""

    ids: list[str]
    kind: np.ndarray  # actor-kind code (messages.ACTOR_KINDS)
    pos: np.ndarray  # (n, 3) [m]
    vel: np.ndarray  # (n, 3) [m/s]

    @property
    def speed(self) -> np.ndarray:
        return np.hypot(self.vel[:, 0], self.vel[:, 1])  # [m/s] over ground


def actor_columns(egos: Sequence[EgoNow], frame: NpcFrame) -> ActorColumns:
    e, rows = EgoColumns.of(egos), frame.rows
    ego_pos = np.stack([e.x, e.y, e.z], axis=1).reshape(-1, 3)
    ego_vel = np.stack([e.vx, e.vy, np.zeros(len(e))], axis=1).reshape(-1, 3)
    npc_pos = np.stack([rows["x"], rows["y"], rows["z"]], axis=1).astype(np.float64)
    npc_vel = np.stack([rows["vx"], rows["vy"], np.zeros(len(rows))], axis=1).astype(np.float64)
    return ActorColumns(
        ids=e.ids + frame.ids,
        kind=np.concatenate([e.kind_codes(), rows["kind"].astype(np.intp)]),
        pos=np.concatenate([ego_pos, npc_pos]),
        vel=np.concatenate([ego_vel, npc_vel]),
    )


EVERY_LISTENER = -1  # `SoundSources.listener` of a source every listener may hear


@dataclass(frozen=True, slots=True)
class SoundSources:
    """Sound sources as columns, one row per source.

    A source on an actor is one row for every listener. A source heard from a place that
    depends on the listener (an area's nearest point, rain around it) is one row per listener
    it concerns, `listener` naming that listener's index.
    """

    ids: list[str]
    owner: np.ndarray  # index of the actor it rides on (egos first), -1 for none
    listener: np.ndarray  # index of the one listener this row is for, or EVERY_LISTENER
    kind: np.ndarray  # index into messages.AUDIO_KINDS
    pos: np.ndarray  # (n, 3) [m]
    vel: np.ndarray  # (n, 3) [m/s]
    level_db: np.ndarray  # [dB SPL] at 1 m
    drive: np.ndarray  # (n, 2) drive_a, drive_b
    extent_m: np.ndarray  # [m] radius of an area source, 0 for a point

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def build(
        cls,
        ids: list[str],
        kind: np.ndarray | int,
        pos: np.ndarray,
        level_db: np.ndarray | float,
        drive: np.ndarray,
        *,
        owner: np.ndarray | int = -1,
        listener: np.ndarray | int = EVERY_LISTENER,
        vel: np.ndarray | None = None,
        extent_m: np.ndarray | float = 0.0,
    ) -> SoundSources:
        """Columns from arrays or one value for all rows."""
        n = len(ids)

        def column(value: np.ndarray | float, dtype: type) -> np.ndarray:
            if isinstance(value, np.ndarray):
                return value.astype(dtype, copy=False)
            return np.full(n, value, dtype=dtype)

        return cls(
            ids,
            column(owner, np.intp),
            column(listener, np.intp),
            column(kind, np.intp),
            np.asarray(pos, dtype=np.float64).reshape(n, 3),
            np.zeros((n, 3)) if vel is None else np.asarray(vel, dtype=np.float64).reshape(n, 3),
            column(level_db, np.float64),
            np.asarray(drive, dtype=np.float64).reshape(n, 2),
            column(extent_m, np.float64),
        )

    def take(self, index: np.ndarray) -> SoundSources:
        """The rows at `index`, in that order."""
        return SoundSources(
            list(map(self.ids.__getitem__, index.tolist())),
            self.owner[index],
            self.listener[index],
            self.kind[index],
            self.pos[index],
            self.vel[index],
            self.level_db[index],
            self.drive[index],
            self.extent_m[index],
        )

    @classmethod
    def concat(cls, parts: Sequence[SoundSources]) -> SoundSources:
        columns = [np.concatenate([getattr(p, f) for p in parts]) for f in _ARRAYS]
        return cls(list(chain.from_iterable(p.ids for p in parts)), *columns)


_ARRAYS = ("owner", "listener", "kind", "pos", "vel", "level_db", "drive", "extent_m")


def _on_actors(
    actors: ActorColumns,
    names: list[str],
    pick: np.ndarray,
    kind: str,
    level: np.ndarray,
    drive: np.ndarray,
) -> SoundSources:
    """Sources of one `kind` (ids `names`, one per actor) on the actors picked by the mask."""
    where = np.flatnonzero(pick)
    return SoundSources.build(
        list(map(names.__getitem__, where.tolist())),
        KIND_INDEX[kind],
        actors.pos[where],
        level[where],
        drive[where],
        owner=where,
        vel=actors.vel[where],
    )


class ActorSounds:
    """Engines, tyres and sirens of all actors; remembers speeds to estimate acceleration."""

    def __init__(self, sirens: Sequence[SirenSpec]) -> None:
        self._engines, self._tyres = EngineBank(), TyreBank()
        self._sirens = {s.vehicle: s for s in sirens}
        self._last_ids: list[str] = []
        self._last_speeds = np.zeros(0)  # [m/s] of those actors
        self._last_t: float | None = None
        # Kept while the actors stay the same, as they do from most ticks to the next:
        self._named_ids: list[str] = []  # the actors these are for
        self._names: dict[str, list[str]] = {}  # kind -> "<actor id>.<kind>" of each actor
        self._siren_pick = np.zeros(0, dtype=bool)  # the actors with a siren

    def sources(self, t: float, actors: ActorColumns, wetness: float) -> SoundSources:
        self._name(actors.ids)
        speed = actors.speed
        accel = self._acceleration(t, actors.ids, speed)
        engine = self._engines.run(actors.kind, speed, accel)
        rolling = self._tyres.has_tyres[actors.kind] & (speed >= MIN_ROLLING_MPS)
        tyre_level = self._tyres.level_db(actors.kind, speed, wetness)
        tyre_drive = np.stack([speed, np.full(len(speed), wetness)], axis=1)
        engine_drive = np.stack([engine.rpm, engine.load], axis=1)
        has_engine = self._engines.has_engine[actors.kind]
        engines, tyres = self._names["engine"], self._names["tyres"]
        parts = [
            _on_actors(actors, engines, has_engine, "engine", engine.level_db, engine_drive),
            _on_actors(actors, tyres, rolling, "tyres", tyre_level, tyre_drive),
        ]
        if self._sirens:
            parts.append(self._siren_sources(actors))
        return SoundSources.concat(parts)

    def _name(self, ids: list[str]) -> None:
        """The source ids and siren mask of these actors (built anew only when they changed)."""
        if ids == self._named_ids:
            return
        self._named_ids = ids
        self._names = {k: [f"{i}.{k}" for i in ids] for k in ("engine", "tyres", "siren")}
        self._siren_pick = np.array([i in self._sirens for i in ids], dtype=bool)

    def _acceleration(self, t: float, ids: list[str], speed: np.ndarray) -> np.ndarray:
        """[m/s²] along the path since the last call; 0 for actors new since then."""
        dt = (t - self._last_t) if self._last_t is not None else 0.0
        if ids == self._last_ids:  # the usual case: the same actors in the same order
            before = self._last_speeds
        else:
            last = dict(zip(self._last_ids, self._last_speeds.tolist(), strict=True))
            now = speed.tolist()
            before = np.array([last.get(i, s) for i, s in zip(ids, now, strict=True)])
        self._last_ids, self._last_speeds, self._last_t = ids, speed, t
        return (speed - before) / dt if dt > 0 else np.zeros(len(ids))

    def _siren_sources(self, actors: ActorColumns) -> SoundSources:
        pick = self._siren_pick
        specs = [self._sirens[actors.ids[i]] for i in np.flatnonzero(pick)]
        level, drive = np.zeros(len(pick)), np.zeros((len(pick), 2))
        level[pick] = [s.level_db for s in specs]
        drive[pick, 0] = [SIREN_PATTERNS.index(s.pattern) for s in specs]
        return _on_actors(actors, self._names["siren"], pick, "siren", level, drive)
