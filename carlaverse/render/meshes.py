"""Building triangle meshes: ribbons along centre lines, filled polygons, prisms and boxes.

One `MeshBuilder` collects many shapes into one Panda3D Geom with per-vertex colours and
normals, so a whole map layer is one draw call rather than thousands. Coordinates are the
world frame (x east, y north, z up) [m]; colours are (r, g, b, a) in 0..1.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from panda3d.core import (
    Geom,
    GeomNode,
    GeomTriangles,
    GeomVertexData,
    GeomVertexFormat,
    GeomVertexWriter,
    Triangulator,
)

Color = tuple[float, float, float, float]
Point2 = tuple[float, float]
Point3 = tuple[float, float, float]
UP: Point3 = (0.0, 0.0, 1.0)
MAX_MITER = 2.0  # a sharp corner's offset grows at most this much (avoids spikes)
# Fixed-function fog is computed per vertex and interpolated, so a 100 m triangle would be
# fogged by its far corners; long surfaces are cut into pieces no longer than this. [m]
MAX_SEGMENT_M = 5.0


class MeshBuilder:
    """Accumulates triangles; `node()` turns them into one GeomNode."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._data = GeomVertexData(name, GeomVertexFormat.get_v3n3c4(), Geom.UH_static)
        self._vertex = GeomVertexWriter(self._data, "vertex")
        self._normal = GeomVertexWriter(self._data, "normal")
        self._color = GeomVertexWriter(self._data, "color")
        self._tris = GeomTriangles(Geom.UH_static)
        self._count = 0

    @property
    def empty(self) -> bool:
        return self._count == 0

    def _add(self, p: Point3, n: Point3, c: Color) -> int:
        self._vertex.add_data3(*p)
        self._normal.add_data3(*n)
        self._color.add_data4(*c)
        self._count += 1
        return self._count - 1

    def quad(self, a: Point3, b: Point3, c: Point3, d: Point3, color: Color) -> None:
        """A flat quad a-b-c-d, counter-clockwise seen from its front."""
        n = _normal(a, b, c)
        i = [self._add(p, n, color) for p in (a, b, c, d)]
        self._tris.add_vertices(i[0], i[1], i[2])
        self._tris.add_vertices(i[0], i[2], i[3])

    def ribbon(self, line: Sequence[Point2], width: float, z: float, color: Color) -> None:
        """A flat strip `width` wide centred on a polyline, facing up."""
        line = densify(line, MAX_SEGMENT_M)
        left = offset_line(line, width / 2)
        right = offset_line(line, -width / 2)
        for k in range(len(line) - 1):
            self.quad((*right[k], z), (*right[k + 1], z), (*left[k + 1], z), (*left[k], z), color)

    def grid(self, bounds: tuple[float, float, float, float], z: float, color: Color,
             cells: int) -> None:  # fmt: skip
        """A flat rectangle cut into cells × cells quads, facing up."""
        xmin, ymin, xmax, ymax = bounds
        dx, dy = (xmax - xmin) / cells, (ymax - ymin) / cells
        for i in range(cells):
            for j in range(cells):
                x0, y0 = xmin + i * dx, ymin + j * dy
                self.quad(
                    (x0, y0, z), (x0 + dx, y0, z), (x0 + dx, y0 + dy, z), (x0, y0 + dy, z), color
                )

    def polygon(self, outline: Sequence[Point2], z: float, color: Color) -> None:
        """A flat filled polygon (any simple outline, either winding), facing up."""
        outline = open_outline(outline)
        if len(outline) < 3:
            return
        tri = Triangulator()
        for x, y in outline:
            tri.add_polygon_vertex(tri.add_vertex(x, y))
        tri.triangulate()
        base = [self._add((x, y, z), UP, color) for x, y in outline]
        for t in range(tri.get_num_triangles()):
            a, b, c = tri.get_triangle_v0(t), tri.get_triangle_v1(t), tri.get_triangle_v2(t)
            if _area2(outline[a], outline[b], outline[c]) < 0:
                b, c = c, b  # keep the front face up whatever the outline's winding
            self._tris.add_vertices(base[a], base[b], base[c])

    def prism(self, outline: Sequence[Point2], z0: float, z1: float, color: Color) -> None:
        """A polygon extruded from z0 to z1: walls and a roof (buildings, kerbs)."""
        outline = open_outline(outline)
        self.polygon(outline, z1, color)
        ccw = list(outline) if polygon_area(outline) > 0 else list(reversed(outline))
        wall = _shade(color, 0.8)
        for (x0, y0), (x1, y1) in zip(ccw, ccw[1:] + ccw[:1], strict=True):
            self.quad((x0, y0, z0), (x1, y1, z0), (x1, y1, z1), (x0, y0, z1), wall)

    def box(self, center: Point3, size: Point3, color: Color) -> None:
        """An axis-aligned box; `center` is the middle of its bottom face."""
        cx, cy, z0 = center
        hx, hy, h = size[0] / 2, size[1] / 2, size[2]
        outline = [(cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy)]
        self.prism(outline, z0, z0 + h, color)
        # the bottom matters for floating things (lamp housings) seen from below
        self.quad(
            (cx - hx, cy - hy, z0), (cx - hx, cy + hy, z0), (cx + hx, cy + hy, z0),
            (cx + hx, cy - hy, z0), _shade(color, 0.6),
        )  # fmt: skip

    def cylinder_x(self, center: Point3, length: float, radius: Point2, color: Color,
                   sides: int = 16) -> None:  # fmt: skip
        """A capped cylinder along x; `radius` (along y, along z) reaches its flat faces.

        The section is a regular polygon (`sides` a multiple of 4) turned so that flats face
        down, up, forward and back: a wheel whose axle is `radius[1]` above the ground rests
        on it along a whole flat, not on one corner. The radii differ for a mesh that is later
        scaled unevenly (the unit-frame actor prototypes), so that it comes out round.
        """
        cx, cy, cz = center
        to_corner = 1.0 / math.cos(math.pi / sides)  # corners lie beyond the flats
        angles = [-math.pi / 2 + math.pi * (2 * k + 1) / sides for k in range(sides)]
        ring = [(cy + radius[0] * to_corner * math.cos(a), cz + radius[1] * to_corner * math.sin(a))
                for a in angles]  # fmt: skip
        x0, x1 = cx - length / 2, cx + length / 2
        for (y0, z0), (y1, z1) in zip(ring, ring[1:] + ring[:1], strict=True):
            self.quad((x0, y0, z0), (x0, y1, z1), (x1, y1, z1), (x1, y0, z0), color)
        cap = _shade(color, 0.8)
        for x, normal, order in ((x1, (1.0, 0.0, 0.0), 1), (x0, (-1.0, 0.0, 0.0), -1)):
            hub = self._add((x, cy, cz), normal, cap)
            rim = [self._add((x, y, z), normal, cap) for y, z in ring]
            for a, b in zip(rim, rim[1:] + rim[:1], strict=True):
                self._tris.add_vertices(hub, *(a, b)[::order])  # counter-clockwise from outside

    def node(self) -> GeomNode:
        geom = Geom(self._data)
        geom.add_primitive(self._tris)
        node = GeomNode(self.name)
        node.add_geom(geom)
        return node


# ----------------------------------------------------------------- 2D helpers


def offset_line(line: Sequence[Point2], distance: float) -> list[Point2]:
    """The polyline moved `distance` to its left (negative: right), with mitred corners."""
    normals = [_left_normal(a, b) for a, b in itertools.pairwise(line)]
    out = []
    for k, (x, y) in enumerate(line):
        n0 = normals[max(0, k - 1)]
        n1 = normals[min(len(normals) - 1, k)]
        mx, my = n0[0] + n1[0], n0[1] + n1[1]
        length = math.hypot(mx, my)
        if length < 1e-9:  # a full reversal: fall back to one side's normal
            mx, my, length = n1[0], n1[1], 1.0
        mx, my = mx / length, my / length
        cos_half = max(mx * n1[0] + my * n1[1], 1 / MAX_MITER)
        out.append((x + mx * distance / cos_half, y + my * distance / cos_half))
    return out


def dashes(line: Sequence[Point2], on_m: float, off_m: float) -> list[list[Point2]]:
    """The pieces of a polyline that are 'on' in an on/off pattern along its length."""
    pieces: list[list[Point2]] = []
    total = line_length(line)
    s = 0.0
    while s < total:
        pieces.append(sub_line(line, s, min(total, s + on_m)))
        s += on_m + off_m
    return [p for p in pieces if len(p) >= 2]


def sub_line(line: Sequence[Point2], s0: float, s1: float) -> list[Point2]:
    """The part of a polyline between arc lengths s0 and s1 [m]."""
    out: list[Point2] = []
    walked = 0.0
    for a, b in itertools.pairwise(line):
        seg = math.dist(a, b)
        if seg > 0 and walked + seg >= s0 and walked <= s1:
            u0 = max(0.0, (s0 - walked) / seg)
            u1 = min(1.0, (s1 - walked) / seg)
            p0, p1 = _lerp(a, b, u0), _lerp(a, b, u1)
            if not out:
                out.append(p0)
            out.append(p1)
        walked += seg
    return out


def densify(line: Sequence[Point2], max_segment_m: float) -> list[Point2]:
    """The polyline with extra points so that no segment is longer than `max_segment_m`."""
    out = [line[0]]
    for a, b in itertools.pairwise(line):
        pieces = max(1, math.ceil(math.dist(a, b) / max_segment_m))
        out.extend(_lerp(a, b, k / pieces) for k in range(1, pieces + 1))
    return out


def open_outline(outline: Sequence[Point2]) -> list[Point2]:
    """The outline without a repeated closing point (SUMO shapes repeat the first)."""
    pts = list(outline)
    if len(pts) > 1 and math.dist(pts[0], pts[-1]) < 1e-6:
        pts.pop()
    return pts


def line_length(line: Sequence[Point2]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(line))


def polygon_area(outline: Sequence[Point2]) -> float:
    """Signed area [m²], positive for counter-clockwise outlines."""
    pts = list(outline)
    return 0.5 * sum(
        x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True)
    )


def _lerp(a: Point2, b: Point2, u: float) -> Point2:
    return (a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u)


def _left_normal(a: Point2, b: Point2) -> Point2:
    dx, dy = b[0] - a[0], b[1] - a[1]
    length = math.hypot(dx, dy) or 1.0
    return (-dy / length, dx / length)


def _area2(a: Point2, b: Point2, c: Point2) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _normal(a: Point3, b: Point3, c: Point3) -> Point3:
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    length = math.sqrt(nx * nx + ny * ny + nz * nz) or 1.0
    return (nx / length, ny / length, nz / length)


def _shade(color: Color, k: float) -> Color:
    return (color[0] * k, color[1] * k, color[2] * k, color[3])
