"""Rectangles on the ground: when two moving ones first touch, and how far apart they are.

Every function takes arrays that broadcast against each other (one element per pair and
instant), so a whole encounter is measured in a few numpy operations. A footprint is the
actor's length x width rectangle centred on its position and turned by its heading.

Time to collision is exact for rectangles that keep their velocities and headings: the
relative motion is then a translation, and by the separating-axis theorem the rectangles
overlap exactly when, on each of the four edge normals n, |n·d| <= h_a(n) + h_b(n) (d the
centre offset, h the half-extent of a rectangle along n). With d = d0 + v t each condition
holds on one interval of t; the first contact is where all four intervals first meet.
"""

from __future__ import annotations

import numpy as np

Array = np.ndarray
_EPS = 1e-9


def axes(yaw: Array) -> tuple[Array, Array]:
    """Unit forward and left vectors, shape (..., 2)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c, s], -1), np.stack([-s, c], -1)


def half_extent(normal: Array, yaw: Array, length: Array, width: Array) -> Array:
    """Half the width of the footprint along `normal` (its support distance)."""
    forward, left = axes(yaw)
    return 0.5 * length * np.abs(_dot(normal, forward)) + 0.5 * width * np.abs(_dot(normal, left))


def time_to_contact(
    offset: Array,
    relative_velocity: Array,
    yaw_a: Array,
    yaw_b: Array,
    size_a: tuple,
    size_b: tuple,
) -> Array:
    """Seconds until footprints a and b first touch (0 if they touch now, inf if never).

    `offset` is centre b minus centre a, `relative_velocity` is v_b - v_a, both (..., 2);
    `size_*` are (length, width) arrays.
    """
    start = np.full(offset.shape[:-1], -np.inf)
    end = np.full(offset.shape[:-1], np.inf)
    fa, la = axes(yaw_a)
    fb, lb = axes(yaw_b)
    for normal in (fa, la, fb, lb):
        reach = half_extent(normal, yaw_a, *size_a) + half_extent(normal, yaw_b, *size_b)
        p, q = _dot(normal, offset), _dot(normal, relative_velocity)
        moving = np.abs(q) > _EPS
        q_safe = np.where(moving, q, 1.0)
        t1, t2 = (-reach - p) / q_safe, (reach - p) / q_safe
        lo = np.where(moving, np.minimum(t1, t2), np.where(np.abs(p) <= reach, -np.inf, np.inf))
        hi = np.where(moving, np.maximum(t1, t2), np.where(np.abs(p) <= reach, np.inf, -np.inf))
        start, end = np.maximum(start, lo), np.minimum(end, hi)
    touching = (start <= end) & (end >= 0)
    return np.where(touching, np.maximum(start, 0.0), np.inf)


def corners(centre: Array, yaw: Array, length: Array | float, width: Array | float) -> Array:
    """The four corners, shape (..., 4, 2), counter-clockwise from front-left."""
    forward, left = axes(yaw)
    half_l = (0.5 * np.asarray(length))[..., None, None]
    half_w = (0.5 * np.asarray(width))[..., None, None]
    signs = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    return (
        centre[..., None, :]
        + signs[:, :1] * half_l * forward[..., None, :]
        + signs[:, 1:] * half_w * left[..., None, :]
    )


def gap(corners_a: Array, corners_b: Array) -> Array:
    """Distance between two footprints given by their corners (0 where they overlap)."""
    apart = np.minimum(
        _points_to_edges(corners_a, corners_b), _points_to_edges(corners_b, corners_a)
    )
    return np.where(_overlap(corners_a, corners_b), 0.0, apart)


def _points_to_edges(points: Array, polygon: Array) -> Array:
    """Smallest distance from any of `points` (..., 4, 2) to any edge of `polygon`."""
    start = polygon[..., None, :, :]  # (..., 1, 4, 2)
    edge = np.roll(polygon, -1, axis=-2)[..., None, :, :] - start
    rel = points[..., :, None, :] - start  # (..., 4, 4, 2)
    along = np.clip(_dot(rel, edge) / np.maximum(_dot(edge, edge), _EPS), 0.0, 1.0)
    nearest = rel - along[..., None] * edge
    return np.sqrt(_dot(nearest, nearest)).min(axis=(-1, -2))


def _overlap(corners_a: Array, corners_b: Array) -> Array:
    """Separating-axis test on the rectangles' edge normals."""
    separated = np.zeros(corners_a.shape[:-2], dtype=bool)
    for poly in (corners_a, corners_b):
        for edge in (poly[..., 1, :] - poly[..., 0, :], poly[..., 2, :] - poly[..., 1, :]):
            pa = _dot(corners_a, edge[..., None, :])
            pb = _dot(corners_b, edge[..., None, :])
            separated |= (pa.max(-1) < pb.min(-1)) | (pb.max(-1) < pa.min(-1))
    return ~separated


def _dot(a: Array, b: Array) -> Array:
    return np.sum(a * b, axis=-1)
