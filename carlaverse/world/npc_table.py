"""NPCs as arrays: a few recent batches kept as received, interpolated only when asked.

The authority sends every NPC at 20 Hz in one `NpcBatch` whose rows are a packed numpy record
array. Building a Python object per NPC per batch costs far more than the rest of a node's
fabric work, and most nodes draw NPCs at most once per frame, some never. So a batch is kept
as it came (ids and a read-only array view of the payload), and `frame(t)` interpolates every
NPC at once with array arithmetic — Hermite on position with the sampled velocities, shortest
arc on yaw — only when a renderer asks. Beyond the batches (or for an NPC new in the later
one) it dead-reckons by the one motion model, `carlaverse.dead_reckoning`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from carlaverse.dead_reckoning import npc_motion, project_many
from carlaverse.messages import ACTOR_KINDS, NPC_DTYPE, NpcBatch
from carlaverse.support.angles import wrap_angles
from carlaverse.world.ego_streams import NEW_TIMELINE_S
from carlaverse.world.remote_actor import InterpolationSettings, StreamTiming, hermite

KEPT_BATCHES = 8  # at 20 Hz, 400 ms: more than any render delay the view will use
_KIND_NAMES = np.array([*ACTOR_KINDS, "other"])


@dataclass(frozen=True, slots=True)
class NpcFrame:
    """Every NPC at one session time `t`, one row per NPC (float64 arrays, SI units)."""

    t: float
    ids: list[str]
    x: np.ndarray  # [m]
    y: np.ndarray
    z: np.ndarray
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s]
    vy: np.ndarray
    extrapolated: np.ndarray  # bool: beyond the newest sample (or before the first)
    rows: np.ndarray  # the NPC_DTYPE rows the frame was made from: extents, kind, lights

    def kinds(self) -> np.ndarray:
        """Kind names (one of ACTOR_KINDS or "other") per NPC."""
        return _KIND_NAMES[np.minimum(self.rows["kind"], len(ACTOR_KINDS))]


@dataclass(frozen=True, slots=True)
class _Batch:
    t: float
    ids: list[str]
    rows: np.ndarray

    def index(self) -> dict[str, int]:
        return {npc_id: i for i, npc_id in enumerate(self.ids)}


class NpcTable:
    """The NPC stream of a session as a node receives it. Not thread-safe: one owner."""

    def __init__(self, settings: InterpolationSettings) -> None:
        self.s = settings
        self.timing = StreamTiming(settings)
        self._batches: deque[_Batch] = deque(maxlen=KEPT_BATCHES)
        self.stale_batches = 0  # arrived after a newer one: dropped

    def add(self, batch: NpcBatch, rx_t: float) -> bool:
        """Keep a batch (False: malformed or older than the newest, dropped)."""
        if len(batch.rows) != len(batch.ids) * NPC_DTYPE.itemsize:
            return False
        if self._batches and batch.t < self._batches[-1].t - NEW_TIMELINE_S:
            self._batches.clear()  # a new timeline (`ego_streams.NEW_TIMELINE_S`): start over
            self.timing = StreamTiming(self.s)
        if self._batches and batch.t <= self._batches[-1].t:
            self.stale_batches += 1
            return False
        self.timing.observe(batch.t, rx_t)
        self._batches.append(_Batch(batch.t, batch.ids, batch.array()))
        return True

    def clear(self) -> None:
        self._batches.clear()

    @property
    def ids(self) -> list[str]:
        return self._batches[-1].ids if self._batches else []

    def __len__(self) -> int:
        return len(self.ids)

    def __contains__(self, npc_id: object) -> bool:
        return npc_id in self.ids

    def __iter__(self) -> Iterator[str]:
        return iter(self.ids)

    def is_expired(self, now: float) -> bool:
        return bool(self._batches) and now - self.timing.last_rx_t > self.s.despawn_timeout_s

    def is_stale(self, now: float) -> bool:
        return now - self.timing.last_rx_t > self.s.stale_after_s

    def frame(self, t: float, max_extrapolation_s: float) -> NpcFrame | None:
        """Every NPC at session time `t`; dead-reckoned at most `max_extrapolation_s` past
        the newest batch (or before the oldest). None before the first batch."""
        if not self._batches:
            return None
        batches = self._batches
        after = next((i for i, b in enumerate(batches) if b.t > t), len(batches))
        if after == len(batches):
            return _extrapolate(batches[-1], t, max_extrapolation_s)
        if after == 0:
            return _extrapolate(batches[0], t, max_extrapolation_s)
        return _interpolate(batches[after - 1], batches[after], t)


def _columns(rows: np.ndarray) -> dict[str, np.ndarray]:
    return {k: rows[k].astype(np.float64) for k in ("x", "y", "z", "yaw", "vx", "vy")}


def _extrapolate(b: _Batch, t: float, limit_s: float) -> NpcFrame:
    dt = max(-limit_s, min(limit_s, t - b.t))
    m = npc_motion(b.rows)
    now = project_many(m, dt)
    flag = np.full(len(b.ids), dt != 0.0)
    return NpcFrame(t, b.ids, now.x, now.y, m.z, now.yaw, now.vx, now.vy, flag, b.rows)


def _interpolate(a: _Batch, b: _Batch, t: float) -> NpcFrame:
    """Between two batches: the NPCs of the later one; those new in it are extrapolated back."""
    h = b.t - a.t
    s = (t - a.t) / h
    cb = _columns(b.rows)
    if a.ids == b.ids:
        ca, known = _columns(a.rows), np.ones(len(b.ids), dtype=bool)
    else:
        where = a.index()
        idx = np.fromiter((where.get(i, -1) for i in b.ids), dtype=np.int64, count=len(b.ids))
        known = idx >= 0
        # Row 0 stands in for newcomers (replaced below); an empty batch has no row 0.
        ca = _columns(a.rows[np.where(known, idx, 0)]) if len(a.ids) else dict(cb)
        ca = {k: np.where(known, v, cb[k]) for k, v in ca.items()}
    x = hermite(ca["x"], ca["vx"], cb["x"], cb["vx"], s, h)
    y = hermite(ca["y"], ca["vy"], cb["y"], cb["vy"], s, h)
    z = ca["z"] + (cb["z"] - ca["z"]) * s
    yaw = wrap_angles(ca["yaw"] + wrap_angles(cb["yaw"] - ca["yaw"]) * s)
    vx = ca["vx"] + (cb["vx"] - ca["vx"]) * s
    vy = ca["vy"] + (cb["vy"] - ca["vy"]) * s
    if not known.all():  # newcomers: dead-reckoned back from their first sample
        back = project_many(npc_motion(b.rows), t - b.t)
        x, y, yaw = (
            np.where(known, x, back.x),
            np.where(known, y, back.y),
            np.where(known, yaw, back.yaw),
        )
        vx, vy = np.where(known, vx, back.vx), np.where(known, vy, back.vy)
    return NpcFrame(t, b.ids, x, y, z, yaw, vx, vy, ~known, b.rows)
