"""Who hears what: each listener is sent only the sources loud enough at its position.

The estimate is free-field spreading from a point, L = L₁ − 20·log10(d / 1 m) (d at least
1 m), ignoring air absorption and ground, which only lower it further: a source this estimate
drops could not have been heard. Above the threshold the loudest `cap` are kept, loudest
first. Sources on actors are judged for every listener in one (listeners × sources) matrix;
the few listener-dependent area sources are added per listener.
"""

from __future__ import annotations

import numpy as np

from carlaverse.authority.sound_sources import PointSources
from carlaverse.messages import AUDIO_KINDS, AudioEmitter

MIN_DISTANCE_M = 1.0  # [m] levels are given at 1 m; nearer counts as 1 m


def levels_at(listeners: np.ndarray, sources: PointSources) -> np.ndarray:
    """(listeners, sources) estimated level [dB SPL] of each source at each listener (L, 3)."""
    d = np.linalg.norm(listeners[:, None, :] - sources.pos[None, :, :], axis=2)  # [m]
    return sources.level_db[None, :] - 20.0 * np.log10(np.maximum(d, MIN_DISTANCE_M))


def loudest(levels: np.ndarray, threshold_db: float, cap: int) -> np.ndarray:
    """Indices of at most `cap` levels at or above the threshold, loudest first."""
    heard = np.flatnonzero(levels >= threshold_db)
    if len(heard) > cap:
        heard = heard[np.argpartition(-levels[heard], cap - 1)[:cap]]
    return heard[np.argsort(-levels[heard], kind="stable")]


def audible_on_actors(
    listeners: np.ndarray,
    listener_ids: list[str],
    sources: PointSources,
    threshold_db: float,
    cap: int,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per listener, (source indices, their levels there) of what it hears, loudest first;
    a listener never hears the sources on its own actor."""
    if not len(sources):
        return [(np.zeros(0, dtype=np.intp), np.zeros(0)) for _ in listener_ids]
    levels = levels_at(listeners, sources)
    own = sources.owner[None, :] == np.array(listener_ids, dtype=str)[:, None]
    levels[own] = -np.inf
    out = []
    for row in levels:
        index = loudest(row, threshold_db, cap)
        out.append((index, row[index]))
    return out


def emitters(sources: PointSources) -> list[AudioEmitter]:
    """The sources as wire emitters, in their order."""
    columns = zip(
        sources.ids,
        [AUDIO_KINDS[k] for k in sources.kind.tolist()],
        sources.pos.tolist(),
        sources.vel.tolist(),
        sources.level_db.tolist(),
        sources.extent_m.tolist(),
        sources.drive.tolist(),
        strict=True,
    )
    return [AudioEmitter(i, k, *p, *v, lv, ext, *d) for i, k, p, v, lv, ext, d in columns]
