"""How fast the scripted driver may go at each waypoint: slow for bends, brake for them early.

A driver takes a bend of radius R no faster than v = √(a_lat·R) (a_lat: the lateral
acceleration it accepts), and starts slowing far enough before it to get there braking at
a_dec: v_i ≤ √(v_{i+1}² + 2·a_dec·Δs). The bend's curvature at a waypoint is the heading
change over `CURVATURE_WINDOW_M` of path each side divided by the window's length, so the
corners of a coarse polyline (a junction lane drawn with four points) count as the bend they
stand for; each waypoint then takes the tightest curvature within `REACH_M` either side,
so the slow speed holds from just before a bend to just after it.
"""

from __future__ import annotations

import math

import numpy as np

CURVATURE_WINDOW_M = 1.5  # [m] each side of a waypoint
REACH_M = 3.0  # [m] a waypoint is as slow as the tightest curvature this near it
STRAIGHT = 1e-6  # [1/m] curvature below which a stretch counts as straight


def headings(points: np.ndarray) -> np.ndarray:
    """[rad] the heading of each segment, unwrapped along the path."""
    d = np.diff(points, axis=0)
    return np.unwrap(np.arctan2(d[:, 1], d[:, 0]))


def curvatures(points: np.ndarray, arc: np.ndarray, window_m: float) -> np.ndarray:
    """[1/m] |heading change| per metre around each waypoint (n waypoints, n ≥ 2)."""
    heading = headings(points)
    mid = (arc[:-1] + arc[1:]) / 2  # where each segment's heading applies
    before = np.interp(arc - window_m, mid, heading)
    after = np.interp(arc + window_m, mid, heading)
    span = np.minimum(arc + window_m, arc[-1]) - np.maximum(arc - window_m, arc[0])
    return np.abs(after - before) / np.maximum(span, 1e-6)


def tightest(kappa: np.ndarray, arc: np.ndarray, reach_m: float) -> np.ndarray:
    """[1/m] the largest of `kappa` within `reach_m` of each waypoint along the path."""
    lo = np.searchsorted(arc, arc - reach_m, side="left")
    hi = np.searchsorted(arc, arc + reach_m, side="right")
    return np.array([kappa[a:b].max() for a, b in zip(lo, hi, strict=True)])


def corner_speeds(
    points: list[tuple[float, float]],
    target_mps: float,
    lateral_accel_mps2: float,
    decel_mps2: float,
    loop_from: int | None = None,
) -> list[float]:
    """[m/s] the speed to hold at each waypoint: at most the target, √(a_lat/κ) in bends, and
    slowing at `decel_mps2` before each. With `loop_from`, the path goes on there after its
    last point, so a bend at the loop's start is braked for at its end."""
    p = np.asarray(points, dtype=float)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    kappa = tightest(curvatures(p, arc, CURVATURE_WINDOW_M), arc, REACH_M)
    cap = np.minimum(target_mps, np.sqrt(lateral_accel_mps2 / np.maximum(kappa, STRAIGHT)))
    speeds = cap.tolist()
    gaps = np.diff(arc).tolist()
    if loop_from is not None:  # the last point leads back to `loop_from`
        gaps.append(math.dist(points[-1], points[loop_from]))
    passes = 1 if loop_from is None else 2  # the second carries the loop's start round
    for _ in range(passes):
        for i in range(len(points) - 1, -1, -1):
            after = i + 1 if i + 1 < len(points) else loop_from
            if after is not None:
                reach = math.sqrt(speeds[after] ** 2 + 2 * decel_mps2 * gaps[i])
                speeds[i] = min(speeds[i], reach)
    return speeds
