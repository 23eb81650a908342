"""The emitters a renderer plays: slots filled from AudioScene updates and local sources.

An update arrives ~20 times a second; between updates a position moves on with its velocity
(dead reckoning) and drive values glide towards their newest value, so nothing the renderer
does steps at an update. An emitter that drops out of the scene (or all of them, when scenes
stop coming) fades out over one block and frees its slot.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from typing import Protocol

import numpy as np

from carlaverse.audio.voicing import KINDS

FREE, LIVE, FADING = 0, 1, 2
SCENE, LOCAL = "scene", "local"  # who owns an emitter: the network scene or this node


class EmitterLike(Protocol):
    """What the renderer reads of an emitter: messages.AudioEmitter has exactly this.
    Read-only, as the frozen message's fields are."""

    @property
    def id(self) -> str: ...
    @property
    def kind(self) -> str: ...
    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def z(self) -> float: ...
    @property
    def vx(self) -> float: ...
    @property
    def vy(self) -> float: ...
    @property
    def vz(self) -> float: ...
    @property
    def level_db(self) -> float: ...
    @property
    def extent_m(self) -> float: ...
    @property
    def drive_a(self) -> float: ...
    @property
    def drive_b(self) -> float: ...


class EmitterSlots:
    """Fixed-capacity arrays of emitter state, one row per slot."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.ids: dict[str, int] = {}
        self.owner: dict[str, str] = {}
        self.state = np.zeros(capacity, dtype=np.int8)
        self.kind = np.zeros(capacity, dtype=np.int64)
        self.position = np.zeros((capacity, 3))  # [m] at time t_ref
        self.velocity = np.zeros((capacity, 3))  # [m/s]
        self.t_ref = np.zeros(capacity)  # [s] render time of `position`
        self.level_db = np.zeros(capacity)  # [dB SPL at 1 m]
        self.extent_m = np.zeros(capacity)
        self.target = np.zeros((capacity, 2))  # newest drive_a, drive_b
        self.drive = np.zeros((capacity, 2))  # glided drive values now
        self.fresh: list[int] = []  # slots that appeared since the last block
        self.dropped: Counter[str] = Counter()  # why an emitter could not be played
        self.last_scene_t = -math.inf

    def apply(self, emitters: Iterable[EmitterLike], t: float, owner: str = SCENE) -> None:
        """Take a scene (or the local sources) valid at render time `t`; an emitter of the
        same owner that is not in it fades out."""
        seen = set()
        for e in emitters:
            slot = self._slot(e, owner)
            if slot is None:
                continue
            seen.add(e.id)
            self._store(slot, e, t)
        for emitter_id, slot in self.ids.items():
            if self.owner[emitter_id] == owner and emitter_id not in seen:
                self.state[slot] = FADING
        if owner == SCENE:
            self.last_scene_t = t

    def _slot(self, e: EmitterLike, owner: str) -> int | None:
        slot = self.ids.get(e.id)
        if slot is not None:
            self.state[slot] = LIVE
            return slot
        if e.kind not in KINDS:
            self.dropped["unknown kind"] += 1
            return None
        free = np.flatnonzero(self.state == FREE)
        if free.size == 0:
            self.dropped["no free slot"] += 1
            return None
        slot = int(free[0])
        self.ids[e.id], self.owner[e.id] = slot, owner
        self.state[slot], self.kind[slot] = LIVE, KINDS.index(e.kind)
        self.drive[slot] = (e.drive_a, e.drive_b)
        self.fresh.append(slot)
        return slot

    def _store(self, slot: int, e: EmitterLike, t: float) -> None:
        self.position[slot] = (e.x, e.y, e.z)
        self.velocity[slot] = (e.vx, e.vy, e.vz)
        self.t_ref[slot] = t
        self.level_db[slot] = e.level_db
        self.extent_m[slot] = e.extent_m
        self.target[slot] = (e.drive_a, e.drive_b)

    def expire(self, t: float, stale_after_s: float) -> None:
        """No scene for `stale_after_s`: the scene's emitters fade out."""
        if t - self.last_scene_t > stale_after_s:
            for emitter_id, slot in self.ids.items():
                if self.owner[emitter_id] == SCENE:
                    self.state[slot] = FADING

    def glide(self, slots: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """Move drive values a `fraction` of the way to their targets; (before, after)."""
        before = self.drive[slots].copy()
        self.drive[slots] += (self.target[slots] - before) * fraction
        return before, self.drive[slots]

    def positions_at(self, slots: np.ndarray, t: float) -> np.ndarray:
        """(E × 3) [m] dead-reckoned to render time `t`."""
        age = (t - self.t_ref[slots])[:, None]
        return self.position[slots] + self.velocity[slots] * age

    def take_fresh(self) -> np.ndarray:
        fresh, self.fresh = np.array(self.fresh, dtype=np.int64), []
        return fresh

    def release(self, slots: np.ndarray) -> None:
        """Free slots that have faded out."""
        gone = set(int(s) for s in slots)
        for emitter_id in [i for i, s in self.ids.items() if s in gone]:
            del self.ids[emitter_id], self.owner[emitter_id]
        self.state[slots] = FREE

    def live(self) -> np.ndarray:
        return np.flatnonzero(self.state != FREE)
