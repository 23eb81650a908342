"""Who hears what: each listener is sent only the sources loud enough at its position.

The estimate is free-field spreading from a point, L = L₁ − 20·log10(d / 1 m) (d at least
1 m), ignoring air absorption and ground, which only lower it further: a source this estimate
drops could not have been heard. Above the threshold the loudest `cap` are kept, loudest
first. Sources every listener may hear go through one (listeners × sources) matrix, of which
each row keeps its loudest `cap`; rows made for one listener (areas, weather) are judged for
that listener alone; then both are ranked together per listener. No step loops over
listeners in Python: the authority's tick stays cheap with many nodes.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import starmap

import numpy as np

from carlaverse.authority.sound_sources import SoundSources
from carlaverse.messages import AUDIO_KINDS, AudioEmitter

MIN_DISTANCE_M = 1.0  # [m] levels are given at 1 m; nearer counts as 1 m


@dataclass(frozen=True, slots=True)
class Heard:
    """The chosen rows, grouped by listener, loudest first within each group."""

    pool: SoundSources  # every source considered: the shared ones, then the listeners' own
    rows: np.ndarray  # the chosen rows of `pool`
    bounds: np.ndarray  # (listeners + 1,): listener l's rows are bounds[l]:bounds[l + 1]

    @property
    def sources(self) -> SoundSources:
        return self.pool.take(self.rows)

    def of(self, listener: int) -> slice:
        return slice(int(self.bounds[listener]), int(self.bounds[listener + 1]))

    def emitters(self) -> list[AudioEmitter]:
        """`emitters(self.sources)`, each source made once however many listeners hear it
        (frozen messages, shared between scenes): a car in earshot of a hundred listeners is
        one object, not a hundred."""
        unique, inverse = np.unique(self.rows, return_inverse=True)
        made = emitters(self.pool.take(unique))
        return list(map(made.__getitem__, inverse.ravel().tolist()))


def audible(
    ears: np.ndarray, shared: SoundSources, own: SoundSources, threshold_db: float, cap: int
) -> Heard:
    """What each listener (row i of `ears`: the actor with `owner` index i) hears, of the
    `shared` sources every listener may hear and the `own` rows made for one listener each.

    A listener never hears the sources riding on its own actor: its node renders those."""
    who_a, row_a, level_a = _loudest_shared(ears, shared, threshold_db, cap)
    mine = own.listener
    d2 = ((own.pos - ears[mine]) ** 2).sum(axis=1)  # [m²]
    level_b = own.level_db - 10.0 * np.log10(np.maximum(d2, MIN_DISTANCE_M**2))
    loud = np.flatnonzero(level_b >= threshold_db)
    who = np.concatenate([who_a, mine[loud]])
    row = np.concatenate([row_a, len(shared) + loud])
    order = np.lexsort((-np.concatenate([level_a, level_b[loud]]), who))  # by listener, loudest
    who, row = who[order], row[order]
    first = np.searchsorted(who, np.arange(len(ears)))
    keep = np.arange(len(who)) - first[who] < cap
    bounds = np.searchsorted(who[keep], np.arange(len(ears) + 1))
    return Heard(SoundSources.concat([shared, own]), row[keep], bounds)


def _loudest_shared(
    ears: np.ndarray, sources: SoundSources, threshold_db: float, cap: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(listener, source row, level) of each listener's loudest `cap` at or above threshold.

    Ranked by d² · 10^(−L₁/10), which orders like the level but needs no logarithm over the
    whole matrix: only the chosen few get their level in decibels."""
    n = len(sources)
    if n == 0 or len(ears) == 0:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp), np.zeros(0)
    # |e − p|² = |e|² + |p|² − 2 e·p: one matrix product instead of three broadcasts
    pos = sources.pos
    # (in place: the matrix is listeners × sources, hundreds by thousands)
    quietness = np.add.outer((ears * ears).sum(1), (pos * pos).sum(1))
    quietness -= 2.0 * ears @ pos.T  # [m²]
    np.maximum(quietness, MIN_DISTANCE_M**2, out=quietness)
    quietness *= np.power(10.0, -sources.level_db / 10.0)
    on_a_listener = (sources.owner >= 0) & (sources.owner < len(ears))
    quietness[sources.owner[on_a_listener], np.flatnonzero(on_a_listener)] = np.inf
    if cap < n:
        top = np.argpartition(quietness, cap - 1, axis=1)[:, :cap]
    else:
        top = np.tile(np.arange(n), (len(ears), 1))
    top_levels = -10.0 * np.log10(np.take_along_axis(quietness, top, axis=1))
    loud = top_levels >= threshold_db
    return np.nonzero(loud)[0], top[loud], top_levels[loud]


def emitters(sources: SoundSources) -> list[AudioEmitter]:
    """The sources as wire emitters, in their order (flat columns: few objects to collect)."""
    kinds = [AUDIO_KINDS[k] for k in sources.kind.tolist()]
    floats = [*sources.pos.T, *sources.vel.T, sources.level_db, sources.extent_m, *sources.drive.T]
    columns = [column.tolist() for column in floats]
    return list(starmap(AudioEmitter, zip(sources.ids, kinds, *columns, strict=True)))
