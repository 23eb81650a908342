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

import itertools
from dataclasses import dataclass
from itertools import starmap

import numpy as np

from carlaverse.authority.scratch import Scratch
from carlaverse.authority.sound_sources import SoundSources
from carlaverse.messages import AUDIO_KINDS, AudioEmitter

MIN_DISTANCE_M = 1.0  # [m] levels are given at 1 m; nearer counts as 1 m
_KIND_NAMES = np.array(AUDIO_KINDS, dtype=object)  # kind index -> name, the wire's string


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
        return self._made().tolist()

    def emitters_by_listener(self) -> list[list[AudioEmitter]]:
        """`emitters()` split per listener: listener l's scene is item l."""
        made = self._made()
        return [made[a:b].tolist() for a, b in itertools.pairwise(self.bounds.tolist())]

    def _made(self) -> np.ndarray:
        """The chosen rows' emitters as an object array, each distinct row made once. Rows
        are marked in a mask of the pool rather than sorted by np.unique: no sort needed."""
        heard = np.zeros(len(self.pool), dtype=bool)
        heard[self.rows] = True
        distinct = np.flatnonzero(heard)
        # fromiter: assigning a list to an object array probes every item as a sequence
        made = np.fromiter(emitters(self.pool.take(distinct)), dtype=object, count=len(distinct))
        return made[(np.cumsum(heard) - 1)[self.rows]]  # row -> its place among `distinct`


def audible(
    ears: np.ndarray,
    shared: SoundSources,
    own: SoundSources,
    threshold_db: float,
    cap: int,
    actors: np.ndarray | None = None,
    scratch: Scratch | None = None,
) -> Heard:
    """What each listener (row i of `ears`, riding on actor `actors[i]`, by default actor i)
    hears, of the `shared` sources every listener may hear and the `own` rows made for one
    listener each. `scratch` lends the matrices' memory from one call to the next.

    A listener never hears the sources riding on its own actor: its node renders those."""
    actor = np.arange(len(ears)) if actors is None else actors
    scratch = scratch if scratch is not None else Scratch()
    who_a, row_a, level_a = _loudest_shared(ears, actor, shared, threshold_db, cap, scratch)
    mine = own.listener
    d2 = ((own.pos - ears[mine]) ** 2).sum(axis=1)  # [m²]
    level_b = own.level_db - 10.0 * np.log10(np.maximum(d2, MIN_DISTANCE_M**2))
    loud = np.flatnonzero(level_b >= threshold_db)
    who = np.concatenate([who_a, mine[loud]])
    row = np.concatenate([row_a, len(shared) + loud])
    kept, bounds = _loudest_each(who, np.concatenate([level_a, level_b[loud]]), len(ears), cap)
    return Heard(SoundSources.concat([shared, own]), row[kept], bounds)


def _loudest_each(
    who: np.ndarray, level_db: np.ndarray, listeners: int, cap: int
) -> tuple[np.ndarray, np.ndarray]:
    """(indices, bounds): each listener's loudest `cap` rows, grouped by listener, loudest
    first; listener l's are indices[bounds[l]:bounds[l + 1]].

    One float key, the listener plus its quietness scaled into [0, 1), sorted once: a
    lexsort of the two keys costs four times as much."""
    if len(who):
        top = level_db.max()
        order = np.argsort(who + (top - level_db) / (top - level_db.min() + 1.0))
    else:
        order = np.zeros(0, dtype=np.intp)
    who = who[order]
    first = np.searchsorted(who, np.arange(listeners))
    keep = np.arange(len(who)) - first[who] < cap
    return order[keep], np.searchsorted(who[keep], np.arange(listeners + 1))


def _loudest_shared(
    ears: np.ndarray,
    actor: np.ndarray,
    sources: SoundSources,
    threshold_db: float,
    cap: int,
    scratch: Scratch,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(listener, source row, level) of each listener's loudest `cap` at or above threshold
    (a few more where levels tie within float32 rounding; the exact ranking after cuts them).

    Ranked by d² · 10^(−L₁/10), which orders like the level but needs no logarithm over the
    whole matrix: only the chosen few get their level in decibels. Each row's cap-th
    quietness comes from a partition of its values; the chosen are the entries at or under
    it, found in one pass (an argpartition moving indices costs twice as much)."""
    n = len(sources)
    if n == 0 or len(ears) == 0:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp), np.zeros(0)
    shape = (len(ears), n)
    quietness = _quietness(ears, sources, scratch.matrix("quietness", shape, np.float64))
    _mute_own(quietness, actor, sources.owner)
    k = min(cap, n) - 1
    # Partitioned in float32, half the cost. Rounding is monotonic, so a row's k-th rounded
    # value is its k-th value rounded, and one float32 step above it bounds that from above:
    # the entries under the bar hold the loudest `cap` and perhaps a few ties (cut later).
    ranked = scratch.matrix("ranked", shape, np.float32)
    np.copyto(ranked, quietness, casting="same_kind")
    ranked.partition(k, axis=1)
    bar = np.nextafter(ranked[:, k], np.float32(np.inf)).astype(np.float64)
    under = np.less_equal(quietness, bar[:, None], out=scratch.matrix("under", shape, bool))
    chosen = np.flatnonzero(under)  # row-major: grouped by listener
    levels = -10.0 * np.log10(quietness.ravel()[chosen])
    loud = levels >= threshold_db
    who, row = np.divmod(chosen[loud], n)
    return who, row, levels[loud]


def _quietness(ears: np.ndarray, sources: SoundSources, out: np.ndarray) -> np.ndarray:
    """`out` (listeners × sources) set to d² · 10^(−L₁/10) [m²], d at least MIN_DISTANCE_M.

    w·|e − p|² = w·|e|² + w·|p|² − 2 w·e·p is one (listeners × 5) by (5 × sources) product;
    coordinates are taken from the listeners' mean so the cancellation stays far below a
    square millimetre at town scale in float64. The product is numpy's own loop (einsum),
    not BLAS: OpenBLAS spreads a product this size over threads that then spin, twice the
    CPU of the work itself on a shared machine."""
    w = np.power(10.0, -sources.level_db / 10.0)
    centre = ears.mean(axis=0)
    e, p = ears - centre, sources.pos - centre
    left = np.column_stack([e, (e * e).sum(axis=1), np.ones(len(e))])
    right = np.vstack([-2.0 * w * p.T, w, w * (p * p).sum(axis=1)])
    np.einsum("ik,kj->ij", left, right, out=out)
    return np.maximum(out, w * MIN_DISTANCE_M**2, out=out)


def _mute_own(quietness: np.ndarray, actor: np.ndarray, owner: np.ndarray) -> None:
    """Sets the sources riding on each listener's own actor to never heard (infinitely quiet)."""
    listener_of = np.full(max(int(owner.max(initial=-1)), int(actor.max(initial=-1))) + 1, -1)
    listener_of[actor] = np.arange(len(actor))
    column = np.flatnonzero(owner >= 0)
    listener = listener_of[owner[column]]
    mine = listener >= 0
    quietness[listener[mine], column[mine]] = np.inf


def emitters(sources: SoundSources) -> list[AudioEmitter]:
    """The sources as wire emitters, in their order (flat columns: few objects to collect)."""
    kinds = _KIND_NAMES[sources.kind].tolist()
    floats = [*sources.pos.T, *sources.vel.T, sources.level_db, sources.extent_m, *sources.drive.T]
    columns = [column.tolist() for column in floats]
    return list(starmap(AudioEmitter, zip(sources.ids, kinds, *columns, strict=True)))
