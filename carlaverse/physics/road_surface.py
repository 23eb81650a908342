"""The road's vertical profile: ISO 8608 roughness along the path, and features in the map.

The map carries no elevation, so a scenario declares the surface (`surface:`, decoded into
`RoadSurface`): a roughness class for the whole road, and speed bumps, kerbs and potholes
placed in the map frame. `RoadProfile.height(x, y, s)` is the road height [m] under a wheel at
(x, y) [m] that has travelled s [m]: the roughness at s plus every feature holding (x, y)
(they add, so a pothole in a kerbed island is a dip in the raised area). Each feature's shape
is C¹ — no slope steps except a kerb's own edge — so the height's second derivative along a
wheel's path, its vertical acceleration before any suspension, is finite everywhere:

    speed bump  z = h/2 · (1 + cos(2π·d/L)),   |d| ≤ L/2, d across its centre line
    kerb        z = h/2 · (1 − cos(π·e/edge)), 0 ≤ e ≤ edge, e inside the outline; h beyond
    pothole     z = −D/2 · (1 + cos(π·r/R)),   r ≤ R from its centre

A lookup at the loop's rate costs a bounding-box test per feature, and the exact test only for
the boxes that hold the point (the roughness: one table read).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import ConfigError, StrictStruct, convert, parse_yaml
from carlaverse.geometry import inside_polygon
from carlaverse.physics.roughness import RoughnessClass, RoughnessProfile

Point = tuple[float, float]  # [m] map frame


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


class SpeedBump(StrictStruct):
    """A hump across the road: a raised cosine of `height_m` over `length_m` of travel."""

    line: Annotated[list[Point], msgspec.Meta(min_length=2, max_length=2)]  # [m] its crest
    height_m: Annotated[float, msgspec.Meta(gt=0, le=0.3)]  # [m] at the crest
    length_m: Annotated[float, msgspec.Meta(gt=0, le=20)]  # [m] base to base, along travel
    name: str = ""

    def __post_init__(self) -> None:
        (x0, y0), (x1, y1) = self.line
        if not _finite(x0, y0, x1, y1) or (x0, y0) == (x1, y1):
            raise ValueError(f"line must be two distinct finite points, got {self.line}")


class Kerb(StrictStruct):
    """A raised area (pavement, island): its outline rises `height_m` over `edge_m` inward."""

    polygon: Annotated[list[Point], msgspec.Meta(min_length=3)]  # [m] map frame
    height_m: Annotated[float, msgspec.Meta(gt=0, le=0.5)]  # [m]
    edge_m: Annotated[float, msgspec.Meta(gt=0, le=2)] = 0.05  # [m] the rounded edge's width
    name: str = ""

    def __post_init__(self) -> None:
        if not all(_finite(*p) for p in self.polygon):
            raise ValueError(f"polygon corners must be finite numbers, got {self.polygon}")


class Pothole(StrictStruct):
    """A round dip of `depth_m` at its centre, cosine-shaped out to `radius_m`."""

    x: float  # [m] map frame
    y: float  # [m]
    radius_m: Annotated[float, msgspec.Meta(gt=0, le=5)]  # [m]
    depth_m: Annotated[float, msgspec.Meta(gt=0, le=0.5)]  # [m]
    name: str = ""

    def __post_init__(self) -> None:
        if not _finite(self.x, self.y):
            raise ValueError(f"x, y must be finite, got ({self.x}, {self.y})")


class RoadSurface(StrictStruct):
    """A scenario's `surface:`; roughness_class None leaves it to the node's `road:` config."""

    roughness_class: RoughnessClass | None = None  # ISO 8608 class of the whole road
    roughness_seed: int = 0  # the profile's seed: the same seed, the same road
    bumps: list[SpeedBump] = []
    kerbs: list[Kerb] = []
    potholes: list[Pothole] = []

    @classmethod
    def from_scenario_yaml(cls, text: str, source: str = "authority/scenario") -> RoadSurface:
        """Read only the `surface:` block, so the rest of a newer scenario cannot stop it.

        Raises ConfigError naming the source and the field path of a bad entry.
        """
        data = parse_yaml(text, source)
        if not isinstance(data, dict):
            raise ConfigError(source, "a scenario is a mapping of sections")
        return convert(data.get("surface") or {}, cls, source)

    def feature_count(self) -> int:
        return len(self.bumps) + len(self.kerbs) + len(self.potholes)


# --------------------------------------------------------------------------- lookup

Box = tuple[float, float, float, float]  # [m] xmin, ymin, xmax, ymax


@dataclass(frozen=True, slots=True)
class _Bump:
    x0: float  # [m] one end of the crest line
    y0: float
    ux: float  # unit vector along the crest
    uy: float
    width_m: float  # crest length
    spec: SpeedBump
    box: Box

    @classmethod
    def of(cls, bump: SpeedBump) -> _Bump:
        (x0, y0), (x1, y1) = bump.line
        width = math.hypot(x1 - x0, y1 - y0)
        pad = bump.length_m / 2.0
        box = (min(x0, x1) - pad, min(y0, y1) - pad, max(x0, x1) + pad, max(y0, y1) + pad)
        return cls(x0, y0, (x1 - x0) / width, (y1 - y0) / width, width, bump, box)

    def height(self, x: float, y: float) -> float:
        dx, dy = x - self.x0, y - self.y0
        along = dx * self.ux + dy * self.uy
        across = dx * self.uy - dy * self.ux
        half = self.spec.length_m / 2.0
        if not 0.0 <= along <= self.width_m or abs(across) > half:
            return 0.0
        return self.spec.height_m / 2.0 * (1.0 + math.cos(math.pi * across / half))


@dataclass(frozen=True, slots=True)
class _Kerb:
    outline: tuple[Point, ...]
    spec: Kerb
    box: Box

    @classmethod
    def of(cls, kerb: Kerb) -> _Kerb:
        xs, ys = [p[0] for p in kerb.polygon], [p[1] for p in kerb.polygon]
        return cls(tuple(kerb.polygon), kerb, (min(xs), min(ys), max(xs), max(ys)))

    def height(self, x: float, y: float) -> float:
        if not inside_polygon(self.outline, x, y):
            return 0.0
        inset = min(_segment_distance(x, y, a, b) for a, b in _edges(self.outline))
        h, edge = self.spec.height_m, self.spec.edge_m
        if inset >= edge:
            return h
        return h / 2.0 * (1.0 - math.cos(math.pi * inset / edge))


@dataclass(frozen=True, slots=True)
class _Pothole:
    spec: Pothole
    box: Box

    @classmethod
    def of(cls, hole: Pothole) -> _Pothole:
        r = hole.radius_m
        return cls(hole, (hole.x - r, hole.y - r, hole.x + r, hole.y + r))

    def height(self, x: float, y: float) -> float:
        p = self.spec
        r = math.hypot(x - p.x, y - p.y)
        if r >= p.radius_m:
            return 0.0
        return -p.depth_m / 2.0 * (1.0 + math.cos(math.pi * r / p.radius_m))


def _edges(outline: tuple[Point, ...]) -> zip[tuple[Point, Point]]:
    return zip(outline, (*outline[1:], outline[0]), strict=True)


def _segment_distance(x: float, y: float, a: Point, b: Point) -> float:
    """Distance [m] from (x, y) to the segment a–b."""
    ex, ey = b[0] - a[0], b[1] - a[1]
    length2 = ex * ex + ey * ey
    t = 0.0 if length2 == 0.0 else max(0.0, min(1.0, ((x - a[0]) * ex + (y - a[1]) * ey) / length2))
    return math.hypot(x - a[0] - t * ex, y - a[1] - t * ey)


class RoadProfile:
    """Road height under a wheel: roughness along its path plus the features where it is."""

    def __init__(self, surface: RoadSurface, roughness: RoughnessProfile | None) -> None:
        self.surface = surface
        self.roughness = roughness  # None: a smooth road
        self._features = (
            [_Bump.of(b) for b in surface.bumps]
            + [_Kerb.of(k) for k in surface.kerbs]
            + [_Pothole.of(p) for p in surface.potholes]
        )

    @classmethod
    def build(cls, surface: RoadSurface, fallback: RoughnessClass | None, seed: int) -> RoadProfile:
        """The surface's roughness class and seed, else `fallback` with `seed` (the node's)."""
        if surface.roughness_class is not None:
            fallback, seed = surface.roughness_class, surface.roughness_seed
        return cls(surface, None if fallback is None else RoughnessProfile(fallback, seed))

    def height(self, x: float, y: float, s: float) -> float:
        """[m] at (x, y) [m] map frame, for a wheel that has travelled s [m]."""
        return self.roughness_height(s) + self.feature_height(x, y)

    def roughness_height(self, s: float) -> float:
        """[m] of the roughness alone, at path distance s [m]."""
        return 0.0 if self.roughness is None else self.roughness.height(s)

    def feature_height(self, x: float, y: float) -> float:
        """[m] of the bumps, kerbs and potholes at (x, y) [m] map frame, summed."""
        z = 0.0
        for feature in self._features:
            x0, y0, x1, y1 = feature.box
            if x0 <= x <= x1 and y0 <= y <= y1:
                z += feature.height(x, y)
        return z

    @property
    def has_features(self) -> bool:
        return bool(self._features)
