"""Sources that depend on where the listener is: map areas, construction zones, the weather.

An area is heard from its point nearest the listener (the listener's own position when it is
inside), with `extent_m` the area's radius so a renderer can spread it; rain and wind surround
the listener. Polygons are kept as one array of edges, so finding the nearest point of every
area in earshot is a few numpy passes per listener; areas whose bounding circle is out of
earshot are skipped first.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.authority import sound_models as sm
from carlaverse.authority.sound_sources import KIND_INDEX, PointSources
from carlaverse.messages import MapArea, Weather
from carlaverse.traffic.soundscape import ConstructionZone

AREA_KINDS = {"vegetation": "leaves", "water": "water"}  # map area kind -> emitter kind
WEATHER_EXTENT_M = 50.0  # [m] rain and wind come from all around


@dataclass(frozen=True, slots=True)
class AreaLevels:
    """Level at 1 m and drive intensity of each area kind under the current weather."""

    leaves: tuple[float, float]  # ([dB SPL], intensity)
    water: tuple[float, float]

    @classmethod
    def of(cls, weather: Weather | None) -> AreaLevels:
        wind = weather.wind_speed_mps if weather is not None else 0.0
        leaves, water = sm.leaves_intensity(wind), sm.water_intensity(wind)
        return cls((sm.leaves_level_db(leaves), leaves), (sm.water_level_db(water), water))


class MapAreaSources:
    """Leaves and water from the map's vegetation and water polygons."""

    def __init__(self, areas: Sequence[MapArea]) -> None:
        heard = [a for a in areas if a.kind in AREA_KINDS and len(a.polygon) >= 3]
        self.ids = [f"{a.id}.{AREA_KINDS[a.kind]}" for a in heard]
        self.kind = np.array([KIND_INDEX[AREA_KINDS[a.kind]] for a in heard], dtype=np.intp)
        starts = [np.asarray(a.polygon, dtype=np.float64) for a in heard]
        self._a = np.concatenate(starts) if starts else np.zeros((0, 2))
        self._b = np.concatenate([np.roll(p, -1, axis=0) for p in starts]) if starts else self._a
        self._poly = np.repeat(np.arange(len(heard)), [len(p) for p in starts]).astype(np.intp)
        self.centre = np.array([p.mean(axis=0) for p in starts]).reshape(-1, 2)
        self.bound_m = np.array(
            [np.hypot(*(p - c).T).max() for p, c in zip(starts, self.centre, strict=True)]
        )  # [m] bounding circle about the vertex mean
        self.extent_m = np.sqrt(np.array([_area(p) for p in starts]) / math.pi).reshape(-1)

    def __len__(self) -> int:
        return len(self.ids)

    def nearest(self, p: np.ndarray, reach_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(area indices, (k, 2) nearest points) of the areas within `reach_m` [m] of p."""
        near = np.hypot(*(self.centre - p).T) - self.bound_m <= reach_m
        if not near.any():
            return np.zeros(0, dtype=np.intp), np.zeros((0, 2))
        sel = near[self._poly]
        a, b, poly = self._a[sel], self._b[sel], self._poly[sel]
        ab = b - a
        f = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
        foot = a + f[:, None] * ab
        d2 = ((foot - p) ** 2).sum(axis=1)
        order = np.lexsort((d2, poly))  # by polygon, nearest edge first
        idx, first = np.unique(poly[order], return_index=True)
        points = foot[order[first]]
        inside = _crossings(p, a, b, poly, len(self)) % 2 == 1
        points[inside[idx]] = p
        return idx, points


def _crossings(p: np.ndarray, a: np.ndarray, b: np.ndarray, poly: np.ndarray, n: int) -> np.ndarray:
    """Per polygon, how many edges a ray from p towards +x crosses (odd = inside)."""
    straddle = (a[:, 1] > p[1]) != (b[:, 1] > p[1])
    dy = np.where(straddle, b[:, 1] - a[:, 1], 1.0)
    x_at = a[:, 0] + (p[1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / dy
    hit = straddle & (p[0] < x_at)
    return np.bincount(poly, weights=hit, minlength=n).astype(np.intp)


def _area(polygon: np.ndarray) -> float:
    """[m²] shoelace formula."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def reach_m(level_db: float | np.ndarray, threshold_db: float) -> np.ndarray:
    """[m] how far a source of `level_db` at 1 m stays at or above `threshold_db`."""
    return np.power(10.0, (np.asarray(level_db) - threshold_db) / 20.0)


class ListenerAreas:
    """All listener-dependent sources of a session: built once, asked per listener."""

    def __init__(self, areas: Sequence[MapArea], zones: Sequence[ConstructionZone]) -> None:
        self._map = MapAreaSources(areas)
        self._zones = list(zones)
        self._zone_xyz = np.array([(z.x, z.y, z.z) for z in zones], dtype=np.float64)
        self._zone_radius = np.array([z.radius_m for z in zones], dtype=np.float64)

    def sources(self, p: np.ndarray, weather: Weather | None, threshold_db: float) -> PointSources:
        """Every area source around the listener at p (3,) [m] that could reach it."""
        parts = [
            self._map_sources(p, AreaLevels.of(weather), threshold_db),
            self._zone_sources(p),
            _weather_sources(p, weather),
        ]
        return PointSources.concat(parts)

    def _map_sources(self, p: np.ndarray, levels: AreaLevels, threshold_db: float) -> PointSources:
        if not len(self._map):
            return _none()
        leaves = self._map.kind == KIND_INDEX["leaves"]
        level_of = np.where(leaves, levels.leaves[0], levels.water[0])
        idx, points = self._map.nearest(p[:2], reach_m(level_of, threshold_db))
        n = len(idx)
        drive = np.zeros((n, 2))
        drive[:, 0] = np.where(leaves[idx], levels.leaves[1], levels.water[1])
        return _sources(
            [self._map.ids[i] for i in idx],
            self._map.kind[idx],
            np.column_stack([points, np.full(n, p[2])]),
            level_of[idx],
            self._map.extent_m[idx],
            drive,
        )

    def _zone_sources(self, p: np.ndarray) -> PointSources:
        zones = self._zones
        if not zones:
            return _none()
        offset = p - self._zone_xyz
        d = np.maximum(np.linalg.norm(offset, axis=1), 1e-9)
        pull = np.minimum(self._zone_radius / d, 1.0)  # to the rim, or stay if inside
        ids = [f"construction.{z.name}" for z in zones]
        kind = np.full(len(zones), KIND_INDEX["construction"])
        level = np.array([z.level_db for z in zones])
        drive = np.column_stack([[z.intensity for z in zones], np.zeros(len(zones))])
        points = self._zone_xyz + offset * pull[:, None]
        return _sources(ids, kind, points, level, self._zone_radius, drive)


def _weather_sources(p: np.ndarray, weather: Weather | None) -> PointSources:
    """Rain and wind at the listener, when there is any."""
    if weather is None:
        return _none()
    found: list[tuple[str, float, float]] = []  # (kind, level [dB SPL], intensity)
    if weather.precipitation >= sm.RAIN_MIN:
        found.append(("rain", sm.rain_level_db(weather.precipitation), weather.precipitation))
    if weather.wind_speed_mps >= sm.WIND_MIN_MPS:
        wind = weather.wind_speed_mps
        found.append(("wind", sm.wind_level_db(wind), sm.wind_intensity(wind)))
    n = len(found)
    return _sources(
        [f"weather.{k}" for k, _, _ in found],
        np.array([KIND_INDEX[k] for k, _, _ in found], dtype=np.intp),
        np.tile(p, (n, 1)),
        np.array([lv for _, lv, _ in found]),
        np.full(n, WEATHER_EXTENT_M),
        np.column_stack([[i for _, _, i in found], np.zeros(n)]),
    )


def _sources(
    ids: list[str],
    kind: np.ndarray,
    pos: np.ndarray,
    level: np.ndarray,
    extent: np.ndarray,
    drive: np.ndarray,
) -> PointSources:
    n = len(ids)
    return PointSources(
        ids,
        np.full(n, "", dtype=str),
        np.asarray(kind, dtype=np.intp),
        pos.reshape(n, 3),
        np.zeros((n, 3)),
        np.asarray(level, dtype=np.float64),
        drive.reshape(n, 2),
        np.asarray(extent, dtype=np.float64),
    )


def _none() -> PointSources:
    return _sources([], np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros((0, 2)))
