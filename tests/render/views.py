"""A pinhole camera worked out by hand, for the static-scene pixel tests.

The rig's documented conventions (carlaverse/render/cameras.py, rig.py): an eye at (x, y, z)
looks along its yaw (counter-clockwise from east), tilted down by its pitch; a simple rig's
horizontal field of view spans the image width, pixels are square, so tan(fov_v / 2) =
tan(fov_h / 2) · h / w. A world point is projected through those alone, never through the
renderer's own cameras.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carlaverse import messages as m
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig

AT_EYE = HeadPosition(x=0.0, y=0.0, z=0.0)  # the camera sits at the Eye itself
# The sun in the north-west, high: every up-facing surface and the faces turned north or west
# are lit, so colours compare without shadows in the way.
NOON = m.Weather(0, 0.0, sun_altitude_deg=55.0, sun_azimuth_deg=315.0)


def config(width: int, height: int, fov_deg: float) -> RenderConfig:
    size = Resolution(width=width, height=height)
    return RenderConfig(output="offscreen", camera=SimpleRig(resolution=size, fov_deg=fov_deg,
                                                            head=AT_EYE))  # fmt: skip


@dataclass(frozen=True, slots=True)
class Pinhole:
    x: float
    y: float
    z: float
    yaw: float  # [rad]
    pitch: float  # [rad], down positive
    width: int
    height: int
    fov_h: float  # [rad]

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forward, right and up of the image, in the world frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        forward = np.array([c * cp, s * cp, -sp])
        right = np.array([s, -c, 0.0])
        up = np.cross(right, forward)
        return forward, right, up

    def project(self, p: tuple[float, float, float]) -> tuple[float, float]:
        """(column, row) of a world point; row 0 is the top, pixel k covers [k, k + 1)."""
        forward, right, up = self.axes()
        d = np.array(p) - np.array([self.x, self.y, self.z])
        depth = float(d @ forward)
        tan_h = math.tan(self.fov_h / 2)
        tan_v = tan_h * self.height / self.width
        col = self.width / 2 * (1 + float(d @ right) / depth / tan_h)
        row = self.height / 2 * (1 - float(d @ up) / depth / tan_v)
        return col, row

    def px_per_m(self, depth_m: float) -> float:
        """Pixels per metre on a plane facing the camera `depth_m` away."""
        return self.width / 2 / math.tan(self.fov_h / 2) / depth_m


def brightness(img: np.ndarray) -> np.ndarray:
    return img.astype(float).mean(axis=2)


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True in a 1-D mask."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))
