"""Plane polylines [m]: where a point falls on one, a parallel one, an even resampling."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import NamedTuple

Point = tuple[float, float]


class Projection(NamedTuple):
    """The nearest point of a polyline to a query point."""

    distance_m: float  # [m] from the query point
    along_m: float  # [m] from the polyline's start
    heading: float  # [rad] of the segment it lies on


def project(line: Sequence[Point], x: float, y: float) -> Projection:
    """The point of `line` (two points or more) nearest to (x, y)."""
    best = Projection(math.inf, 0.0, 0.0)
    walked = 0.0
    for (ax, ay), (bx, by) in itertools.pairwise(line):
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        t = 0.0 if length == 0 else min(1.0, max(0.0, ((x - ax) * dx + (y - ay) * dy) / length**2))
        gap = math.hypot(ax + t * dx - x, ay + t * dy - y)
        if gap < best.distance_m:
            best = Projection(gap, walked + t * length, math.atan2(dy, dx))
        walked += length
    return best


def length(line: Sequence[Point]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(line))


def offset_right(line: Sequence[Point], offset_m: float) -> list[Point]:
    """The line `offset_m` to the right of `line` (left when negative), corners mitred."""
    normals = []
    for (ax, ay), (bx, by) in itertools.pairwise(line):
        d = math.hypot(bx - ax, by - ay) or 1.0
        normals.append(((by - ay) / d, -(bx - ax) / d))  # the right-hand normal
    out = []
    for i, (x, y) in enumerate(line):
        n1 = normals[max(0, i - 1)]
        n2 = normals[min(len(normals) - 1, i)]
        nx, ny = n1[0] + n2[0], n1[1] + n2[1]
        norm = math.hypot(nx, ny)
        if norm < 1e-9:  # a reversal: keep the segment's own normal
            nx, ny, norm = n2[0], n2[1], 1.0
        nx, ny = nx / norm, ny / norm
        scale = offset_m / max(0.5, nx * n2[0] + ny * n2[1])  # mitre, capped at 2x
        out.append((x + nx * scale, y + ny * scale))
    return out


def resample(line: Sequence[Point], step_m: float, start_m: float = 0.0) -> list[Point]:
    """Points every `step_m` along `line` from `start_m` to its end (the end included)."""
    out: list[Point] = []
    target, walked = start_m, 0.0
    for (ax, ay), (bx, by) in itertools.pairwise(line):
        seg = math.hypot(bx - ax, by - ay)
        while seg > 0 and target <= walked + seg:
            t = (target - walked) / seg
            out.append((ax + t * (bx - ax), ay + t * (by - ay)))
            target += step_m
        walked += seg
    if line and (not out or math.dist(out[-1], line[-1]) > 1e-6):
        out.append((float(line[-1][0]), float(line[-1][1])))
    return out


def join(pieces: Sequence[Sequence[Point]]) -> list[Point]:
    """The pieces end to end, without repeating a point where one ends and the next begins."""
    out: list[Point] = []
    for piece in pieces:
        for point in piece:
            if not out or math.dist(out[-1], point) > 1e-3:
                out.append((float(point[0]), float(point[1])))
    return out
