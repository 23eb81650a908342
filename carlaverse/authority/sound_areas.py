"""Sources that depend on where the listener is: map areas, construction zones, the weather.

An area is heard from its point nearest the listener (the listener's own position when it is
inside), with `extent_m` the area's radius so a renderer can spread it; rain and wind surround
the listener. Polygons are kept as one array of edges; areas whose bounding circle is out of a
listener's earshot are dropped first, then the nearest point of every remaining (listener,
area) pair is found in a few numpy passes over all their edges at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.authority import sound_models as sm
from carlaverse.authority.scratch import Scratch
from carlaverse.authority.sound_sources import KIND_INDEX, SoundSources
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
    """Leaves and water from the map's vegetation and water polygons, edges as one array."""

    def __init__(self, areas: Sequence[MapArea]) -> None:
        heard = [a for a in areas if a.kind in AREA_KINDS and len(a.polygon) >= 3]
        polygons = [np.asarray(a.polygon, dtype=np.float64) for a in heard]
        self.ids = [f"{a.id}.{AREA_KINDS[a.kind]}" for a in heard]
        self.kind = np.array([KIND_INDEX[AREA_KINDS[a.kind]] for a in heard], dtype=np.intp)
        self._a = np.concatenate(polygons) if polygons else np.zeros((0, 2))  # edge starts
        self._b = (
            np.concatenate([np.roll(q, -1, axis=0) for q in polygons]) if polygons else self._a
        )
        self._count = np.array([len(q) for q in polygons], dtype=np.intp)  # edges per polygon
        self._first = np.cumsum(self._count) - self._count  # its first edge
        self.centre = np.array([q.mean(axis=0) for q in polygons]).reshape(-1, 2)
        # [m] bounding circle about the vertex mean, and the radius of a disc of equal area
        self.bound_m = np.array([np.hypot(*(q - q.mean(axis=0)).T).max() for q in polygons])
        self.extent_m = np.sqrt(np.array([_area(q) for q in polygons]) / math.pi).reshape(-1)
        self._scratch = Scratch()

    def __len__(self) -> int:
        return len(self.ids)

    def nearest(
        self, ears: np.ndarray, reach_m: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(listener, area, nearest point (k, 2)) for every listener and area within `reach_m`
        [m] of it; the point is the listener's own where it stands inside the area."""
        listener, area = self._within(ears, reach_m)
        if not len(area):
            return listener, area, np.zeros((0, 2))
        counts = self._count[area]
        group = np.repeat(np.arange(len(area)), counts)  # pair of each (pair, edge) row
        starts = np.cumsum(counts) - counts
        edge = self._first[area][group] + np.arange(counts.sum()) - starts[group]
        p, a, b = ears[listener][group], self._a[edge], self._b[edge]
        ab = b - a
        f = np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
        foot = a + np.clip(f, 0.0, 1.0)[:, None] * ab
        d2 = np.einsum("ij,ij->i", foot - p, foot - p)
        closest = np.lexsort((d2, group))[starts]  # groups are contiguous: sorted by d2 within
        inside = np.add.reduceat(_crosses(p, a, b), starts) % 2 == 1
        points = np.where(inside[:, None], ears[listener], foot[closest])
        return listener, area, points

    def _within(self, ears: np.ndarray, reach_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(listener, area) pairs whose bounding circle is within `reach_m` of the listener:
        |gap|² ≤ (bound + reach)², in reused matrices, squared per axis (np.hypot over a
        broadcast view costs ten times as much)."""
        shape = (len(ears), len(self))
        dx = np.subtract.outer(
            ears[:, 0], self.centre[:, 0], out=self._scratch.matrix("dx", shape, np.float64)
        )
        dy = np.subtract.outer(
            ears[:, 1], self.centre[:, 1], out=self._scratch.matrix("dy", shape, np.float64)
        )
        dx *= dx
        dy *= dy
        dx += dy
        near = np.less_equal(
            dx, (self.bound_m + reach_m) ** 2, out=self._scratch.matrix("near", shape, bool)
        )
        listener, area = np.divmod(np.flatnonzero(near), len(self))
        return listener, area


def _crosses(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row, whether the edge a→b crosses the ray from p towards +x (odd count = inside)."""
    straddle = (a[:, 1] > p[:, 1]) != (b[:, 1] > p[:, 1])
    dy = np.where(straddle, b[:, 1] - a[:, 1], 1.0)
    x_at = a[:, 0] + (p[:, 1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / dy
    return (straddle & (p[:, 0] < x_at)).astype(np.intp)


def _area(polygon: np.ndarray) -> float:
    """[m²] shoelace formula."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def reach_m(level_db: float | np.ndarray, threshold_db: float) -> np.ndarray:
    """[m] how far a source of `level_db` at 1 m stays at or above `threshold_db`."""
    return np.power(10.0, (np.asarray(level_db) - threshold_db) / 20.0)


class ListenerAreas:
    """All listener-dependent sources of a session: built once, asked every audio instant."""

    def __init__(self, areas: Sequence[MapArea], zones: Sequence[ConstructionZone]) -> None:
        self._map = MapAreaSources(areas)
        self._zone_ids = [f"construction.{z.name}" for z in zones]
        self._zone_xyz = np.array([(z.x, z.y, z.z) for z in zones], dtype=np.float64).reshape(-1, 3)
        self._zone_radius = np.array([z.radius_m for z in zones], dtype=np.float64)
        self._zone_level = np.array([z.level_db for z in zones], dtype=np.float64)
        self._zone_intensity = np.array([z.intensity for z in zones], dtype=np.float64)

    def sources(
        self, ears: np.ndarray, weather: Weather | None, threshold_db: float
    ) -> SoundSources:
        """One row per listener (ears: (L, 3) [m]) and area source that could reach it."""
        parts = [
            self._map_sources(ears, AreaLevels.of(weather), threshold_db),
            self._zone_sources(ears),
            *_weather_sources(ears, weather),
        ]
        return SoundSources.concat(parts)

    def _map_sources(
        self, ears: np.ndarray, levels: AreaLevels, threshold_db: float
    ) -> SoundSources:
        leaves = self._map.kind == KIND_INDEX["leaves"]
        level = np.where(leaves, levels.leaves[0], levels.water[0])
        intensity = np.where(leaves, levels.leaves[1], levels.water[1])
        listener, area, points = self._map.nearest(ears[:, :2], reach_m(level, threshold_db))
        pos = np.column_stack([points, ears[listener, 2]])
        drive = np.column_stack([intensity[area], np.zeros(len(area))])
        ids = [self._map.ids[i] for i in area.tolist()]
        return SoundSources.build(
            ids,
            self._map.kind[area],
            pos,
            level[area],
            drive,
            listener=listener,
            extent_m=self._map.extent_m[area],
        )

    def _zone_sources(self, ears: np.ndarray) -> SoundSources:
        """A zone is heard from its rim (from where the listener stands, inside it)."""
        n_ears, n_zones = len(ears), len(self._zone_ids)
        offset = ears[:, None, :] - self._zone_xyz[None, :, :]  # (L, Z, 3)
        d = np.maximum(np.linalg.norm(offset, axis=2), 1e-9)
        pull = np.minimum(self._zone_radius / d, 1.0)[:, :, None]
        drive = np.column_stack([np.tile(self._zone_intensity, n_ears), np.zeros(n_ears * n_zones)])
        return SoundSources.build(
            self._zone_ids * n_ears,
            KIND_INDEX["construction"],
            self._zone_xyz + offset * pull,
            np.tile(self._zone_level, n_ears),
            drive,
            listener=np.repeat(np.arange(n_ears), n_zones),
            extent_m=np.tile(self._zone_radius, n_ears),
        )


def _weather_sources(ears: np.ndarray, weather: Weather | None) -> list[SoundSources]:
    """Rain and wind around every listener, when there is any."""
    if weather is None:
        return []
    found: list[tuple[str, float, float]] = []  # (kind, level [dB SPL], intensity)
    if weather.precipitation >= sm.RAIN_MIN:
        found.append(("rain", sm.rain_level_db(weather.precipitation), weather.precipitation))
    if weather.wind_speed_mps >= sm.WIND_MIN_MPS:
        wind = weather.wind_speed_mps
        found.append(("wind", sm.wind_level_db(wind), sm.wind_intensity(wind)))
    n = len(ears)
    return [
        SoundSources.build(
            [f"weather.{kind}"] * n,
            KIND_INDEX[kind],
            ears,
            level,
            np.column_stack([np.full(n, intensity), np.zeros(n)]),
            listener=np.arange(n),
            extent_m=WEATHER_EXTENT_M,
        )
        for kind, level, intensity in found
    ]
