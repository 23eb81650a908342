"""Oriented boxes in the plane, with heights: the geometry of the collision matrix.

All functions work on numpy columns, one entry per box or per candidate pair, so a tick with
a thousand actors costs a handful of array operations rather than a Python loop per pair:
a sweep-and-prune broadphase on axis-aligned bounds, then a separating-axis narrowphase on
the oriented boxes (2D), gated by the vertical overlap of the boxes' height intervals.

A box is its centre (x, y), yaw [rad], half length `hl` along the heading and half width
`hw`, and the interval [z, z + h] (z is the bottom of the box).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def aabb_half_extents(hl: np.ndarray, hw: np.ndarray, yaw: np.ndarray) -> tuple[np.ndarray, ...]:
    """Half sizes along x and y of the axis-aligned box around each oriented box."""
    c, s = np.abs(np.cos(yaw)), np.abs(np.sin(yaw))
    return c * hl + s * hw, s * hl + c * hw


def sweep_and_prune(
    xmin: np.ndarray, xmax: np.ndarray, ymin: np.ndarray, ymax: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i < j in sweep order) whose axis-aligned boxes overlap.

    Sort by xmin; each box's x-overlapping successors are the contiguous run that starts
    before its xmax (one `searchsorted`); the runs are expanded without a Python loop and
    then pruned on y.
    """
    n = len(xmin)
    if n < 2:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    order = np.argsort(xmin, kind="stable")
    sx_min, sx_max = xmin[order], xmax[order]
    ends = np.searchsorted(sx_min, sx_max, side="right")
    starts = np.arange(1, n + 1)
    counts = np.maximum(ends - starts, 0)
    total = int(counts.sum())
    first = np.repeat(np.arange(n), counts)
    run_start = np.repeat(np.cumsum(counts) - counts, counts)
    second = np.arange(total) - run_start + np.repeat(starts, counts)
    i, j = order[first], order[second]
    keep = (ymin[i] <= ymax[j]) & (ymin[j] <= ymax[i])
    return i[keep], j[keep]


@dataclass(frozen=True, slots=True)
class Overlaps:
    """Narrowphase result for candidate pairs (a[k], b[k])."""

    hit: np.ndarray  # bool: the boxes intersect
    depth: np.ndarray  # [m] penetration along the normal (> 0 where hit)
    normal: np.ndarray  # (k, 2) unit, pointing from box b into box a


def box_overlaps(
    a: np.ndarray,
    b: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    hl: np.ndarray,
    hw: np.ndarray,
    z: np.ndarray,
    h: np.ndarray,
) -> Overlaps:
    """Separating-axis test of box a[k] against box b[k] for every candidate pair k."""
    d = np.stack([x[b] - x[a], y[b] - y[a]], axis=1)  # centre a -> centre b
    ca, sa, cb, sb = np.cos(yaw[a]), np.sin(yaw[a]), np.cos(yaw[b]), np.sin(yaw[b])
    # The four candidate separating axes: each box's heading and its normal.
    axes = np.stack(
        [
            np.stack([ca, sa], 1),
            np.stack([-sa, ca], 1),
            np.stack([cb, sb], 1),
            np.stack([-sb, cb], 1),
        ],
        axis=1,
    )
    ra = _radius(axes, ca, sa, hl[a], hw[a])
    rb = _radius(axes, cb, sb, hl[b], hw[b])
    along = np.einsum("kad,kd->ka", axes, d)
    overlap = ra + rb - np.abs(along)  # [m] per axis; <= 0 means that axis separates
    best = np.argmin(overlap, axis=1)
    rows = np.arange(len(a))
    depth = overlap[rows, best]
    sign = np.where(along[rows, best] > 0, -1.0, 1.0)
    normal = axes[rows, best] * sign[:, None]
    vertical = (z[a] < z[b] + h[b]) & (z[b] < z[a] + h[a])
    return Overlaps((depth > 0) & vertical, depth, normal)


def _radius(
    axes: np.ndarray, c: np.ndarray, s: np.ndarray, hl: np.ndarray, hw: np.ndarray
) -> np.ndarray:
    """Half the extent of each box projected on each of the candidate axes."""
    u = np.abs(axes[:, :, 0] * c[:, None] + axes[:, :, 1] * s[:, None])
    v = np.abs(-axes[:, :, 0] * s[:, None] + axes[:, :, 1] * c[:, None])
    return hl[:, None] * u + hw[:, None] * v


def corners(x: float, y: float, yaw: float, hl: float, hw: float) -> list[tuple[float, float]]:
    """The four corners of one box, counter-clockwise."""
    c, s = np.cos(yaw), np.sin(yaw)
    local = ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))
    return [(x + c * u - s * v, y + s * u + c * v) for u, v in local]


def intersection_centroid(
    p: list[tuple[float, float]], q: list[tuple[float, float]]
) -> tuple[float, float]:
    """Centroid of the overlap of two convex counter-clockwise polygons (the contact point).

    Falls back to the midpoint of the two centroids when the overlap is degenerate.
    """
    clipped = p
    for k in range(len(q)):
        a, b = q[k], q[(k + 1) % len(q)]
        clipped = _clip(clipped, a, b)
        if not clipped:
            break
    if len(clipped) >= 3:
        return _centroid(clipped)
    pc, qc = _centroid(p), _centroid(q)
    return ((pc[0] + qc[0]) / 2, (pc[1] + qc[1]) / 2)


def _clip(poly: list[tuple[float, float]], a: tuple[float, float], b: tuple[float, float]):
    """Sutherland-Hodgman: the part of `poly` left of the directed edge a -> b."""

    def side(p: tuple[float, float]) -> float:
        return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])

    out = []
    for k, cur in enumerate(poly):
        prev = poly[k - 1]
        sc, sp = side(cur), side(prev)
        if sc >= 0:
            if sp < 0:
                out.append(_cross_point(prev, cur, sp, sc))
            out.append(cur)
        elif sp >= 0:
            out.append(_cross_point(prev, cur, sp, sc))
    return out


def _cross_point(p, q, sp: float, sq: float) -> tuple[float, float]:
    t = sp / (sp - sq)
    return (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]))


def _centroid(poly: list[tuple[float, float]]) -> tuple[float, float]:
    area = cx = cy = 0.0
    for k, (x0, y0) in enumerate(poly):
        x1, y1 = poly[(k + 1) % len(poly)]
        cross = x0 * y1 - x1 * y0
        area += cross
        cx += (x0 + x1) * cross
        cy += (y0 + y1) * cross
    if abs(area) < 1e-12:
        return (sum(p[0] for p in poly) / len(poly), sum(p[1] for p in poly) / len(poly))
    return (cx / (3 * area), cy / (3 * area))
