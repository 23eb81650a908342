"""Solids for road users, built from `MeshBuilder.quad`: slanted beams, side profiles, rings.

Coordinates are Panda3D's actor frame (x right, y forward, z up); every face is wound
counter-clockwise seen from outside, so back-face culling keeps the outside. A triangle is a
quad with its last corner repeated (the second half is empty and draws nothing).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from carlaverse.render.meshes import Color, MeshBuilder, Point2, Point3


def _sub(a: Point3, b: Point3) -> Point3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Point3, b: Point3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Point3, b: Point3) -> Point3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _unit(a: Point3) -> Point3:
    n = math.sqrt(_dot(a, a)) or 1.0
    return (a[0] / n, a[1] / n, a[2] / n)


def _at(p: Point3, *terms: tuple[Point3, float]) -> Point3:
    x, y, z = p
    for v, k in terms:
        x, y, z = x + v[0] * k, y + v[1] * k, z + v[2] * k
    return (x, y, z)


def facing(mesh: MeshBuilder, corners: Sequence[Point3], outward: Point3, color: Color) -> None:
    """A flat quad (or triangle: three corners) turned so that its front faces `outward`."""
    pts = list(corners) + ([corners[-1]] if len(corners) == 3 else [])
    if _dot(_cross(_sub(pts[1], pts[0]), _sub(pts[2], pts[0])), outward) < 0:
        pts = (
            [pts[0], *reversed(pts[1:])] if len(corners) == 4 else [pts[0], pts[2], pts[1], pts[1]]
        )
    mesh.quad(pts[0], pts[1], pts[2], pts[3], color)


def beam(mesh: MeshBuilder, a: Point3, b: Point3, width: float, depth: float,
         color: Color) -> None:  # fmt: skip
    """A box from a to b: `width` along the axis nearest to x, `depth` across both."""
    d = _unit(_sub(b, a))
    ref: Point3 = (1.0, 0.0, 0.0) if abs(d[0]) < 0.9 else (0.0, 1.0, 0.0)
    u = _unit(_at(ref, (d, -_dot(ref, d))))
    w = _cross(d, u)
    hu, hw = width / 2, depth / 2
    ring = [(su, sw) for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    low = [_at(a, (u, su * hu), (w, sw * hw)) for su, sw in ring]
    high = [_at(b, (u, su * hu), (w, sw * hw)) for su, sw in ring]
    for k in range(4):
        j = (k + 1) % 4
        out = _at((0.0, 0.0, 0.0), (u, ring[k][0] + ring[j][0]), (w, ring[k][1] + ring[j][1]))
        facing(mesh, (low[k], low[j], high[j], high[k]), out, color)
    facing(mesh, low, (-d[0], -d[1], -d[2]), color)
    facing(mesh, high, d, color)


def profile_x(mesh: MeshBuilder, outline: Sequence[Point2], x0: float, x1: float,
              color: Color, sides: Color | None = None) -> None:  # fmt: skip
    """A convex side outline (y forward, z up) extruded across from x0 to x1."""
    cy = sum(p[0] for p in outline) / len(outline)
    cz = sum(p[1] for p in outline) / len(outline)
    n = len(outline)
    for k in range(n):
        (y0, z0), (y1, z1) = outline[k], outline[(k + 1) % n]
        out = (0.0, (y0 + y1) / 2 - cy, (z0 + z1) / 2 - cz)
        facing(mesh, ((x0, y0, z0), (x1, y0, z0), (x1, y1, z1), (x0, y1, z1)), out, color)
    cap = sides or color
    for x, sign in ((x0, -1.0), (x1, 1.0)):
        for k in range(1, n - 1):
            tri = [(x, *outline[0]), (x, *outline[k]), (x, *outline[k + 1])]
            facing(mesh, tri, (sign, 0.0, 0.0), cap)


def disc_x(mesh: MeshBuilder, center: Point3, radius: Point2, side: float, color: Color,
           sides: int = 12) -> None:  # fmt: skip
    """A flat disc in the plane x = center[0], facing +x (side 1) or −x (side −1): a fan whose
    vertices its triangles share (every wheel of every vehicle has two, each vertex lit per
    frame by the cpu preset)."""
    cx, cy, cz = center
    rim = [(cx, y, z) for y, z in _ring(cy, cz, radius, sides)]
    mesh.fan((cx, cy, cz), rim, (side, 0.0, 0.0), color)


def ring_x(mesh: MeshBuilder, center: Point3, width: float, outer: float, inner: float,
           color: Color, sides: int = 16) -> None:  # fmt: skip
    """A tyre without a wheel: a hollow cylinder along x, radii `outer` > `inner` [m]."""
    cx, cy, cz = center
    x0, x1 = cx - width / 2, cx + width / 2
    rings = {r: _ring(cy, cz, (r, r), sides) for r in (outer, inner)}
    for r, sign in ((outer, 1.0), (inner, -1.0)):
        pts = rings[r]
        for (y0, z0), (y1, z1) in zip(pts, pts[1:] + pts[:1], strict=True):
            out = (0.0, sign * ((y0 + y1) / 2 - cy), sign * ((z0 + z1) / 2 - cz))
            facing(mesh, ((x0, y0, z0), (x0, y1, z1), (x1, y1, z1), (x1, y0, z0)), out, color)
    o, i = rings[outer], rings[inner]
    for x, sign in ((x0, -1.0), (x1, 1.0)):
        for k in range(sides):
            j = (k + 1) % sides
            quad = ((x, *o[k]), (x, *o[j]), (x, *i[j]), (x, *i[k]))
            facing(mesh, quad, (sign, 0.0, 0.0), color)


def _ring(cy: float, cz: float, radius: Point2, sides: int) -> list[Point2]:
    """A regular polygon turned so that a flat faces down (a wheel rests on it)."""
    to_corner = 1.0 / math.cos(math.pi / sides)
    angles = [-math.pi / 2 + math.pi * (2 * k + 1) / sides for k in range(sides)]
    return [(cy + radius[0] * to_corner * math.cos(a), cz + radius[1] * to_corner * math.sin(a))
            for a in angles]  # fmt: skip
