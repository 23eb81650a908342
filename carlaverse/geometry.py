"""Plane geometry shared by the map's users (renderer, scenario grades): pure Python, no engine."""

from __future__ import annotations

from collections.abc import Sequence

Point2 = tuple[float, float]  # [m] map frame


def inside_polygon(outline: Sequence[Point2], x: float, y: float) -> bool:
    """Whether (x, y) lies inside the closed outline, by the even-odd rule."""
    hit = False
    for (x0, y0), (x1, y1) in zip(outline, [*outline[1:], outline[0]], strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit
