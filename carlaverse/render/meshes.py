"""Building triangle meshes: ribbons along centre lines, filled polygons, prisms, boxes, spheres.

One `MeshBuilder` collects many shapes into one Panda3D Geom with per-vertex colours and
normals, so a whole map layer is one draw call rather than thousands. Coordinates are the
world frame (x east, y north, z up) [m]; colours are (r, g, b, a) in 0..1.

A builder given a texture also writes texture coordinates: by default the vertex's (x, y)
in metres divided by the metres one repeat covers (`tile_m`), so that ground surfaces of any
shape share one seamless, true-to-scale pattern; walls pass their own (`uvs`). Further
textures on the same coordinates go on named stages (`add_texture`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

from panda3d.core import (
    BoundingVolume,
    Geom,
    GeomNode,
    GeomTriangles,
    GeomVertexData,
    GeomVertexFormat,
    GeomVertexWriter,
    RenderAttrib,
    RenderState,
    Texture,
    TextureAttrib,
    TextureStage,
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

    def __init__(
        self, name: str, texture: Texture | None = None, tile_m: tuple[float, float] = (1.0, 1.0)
    ) -> None:
        self.name = name
        textured = texture is not None
        fmt = GeomVertexFormat.get_v3n3c4t2() if textured else GeomVertexFormat.get_v3n3c4()
        self._data = GeomVertexData(name, fmt, Geom.UH_static)
        self._vertex = GeomVertexWriter(self._data, "vertex")
        self._normal = GeomVertexWriter(self._data, "normal")
        self._color = GeomVertexWriter(self._data, "color")
        self._uv = GeomVertexWriter(self._data, "texcoord") if textured else None
        self._tile_m = tile_m
        self._stages: list[tuple[TextureStage, Texture]] = []
        self._attribs: list[RenderAttrib] = []
        if texture is not None:
            self._stages.append((TextureStage.get_default(), texture))
        self._tris = GeomTriangles(Geom.UH_static)
        self._count = 0
        # cull by a box rather than Panda3D's default sphere: a sphere round a flat tile of
        # ground reaches over the eye's plane and would keep tiles behind the eye drawn
        self.box_bounds = False

    @property
    def empty(self) -> bool:
        return self._count == 0

    @property
    def triangles(self) -> int:
        return self._tris.get_num_vertices() // 3

    def add_attrib(self, attrib: RenderAttrib) -> None:
        """A render attribute of the whole mesh (transparency, say)."""
        self._attribs.append(attrib)

    def add_texture(self, stage: TextureStage, texture: Texture) -> None:
        """Another texture on the same coordinates (a textured builder only)."""
        if self._uv is None:
            raise ValueError(f"mesh {self.name!r} has no texture coordinates for {stage.name!r}")
        self._stages.append((stage, texture))

    def _add(self, p: Point3, n: Point3, c: Color, uv: Point2 | None = None) -> int:
        self._vertex.add_data3(*p)
        self._normal.add_data3(*n)
        self._color.add_data4(*c)
        if self._uv is not None:
            if uv is None:  # ground: metres east and north, one repeat per tile
                uv = (p[0] / self._tile_m[0], p[1] / self._tile_m[1])
            self._uv.add_data2(*uv)
        self._count += 1
        return self._count - 1

    def quad(self, a: Point3, b: Point3, c: Point3, d: Point3, color: Color,
             uvs: Sequence[Point2] | None = None) -> None:  # fmt: skip
        """A flat quad a-b-c-d, counter-clockwise seen from its front (`uvs`: its corners')."""
        n = _normal(a, b, c)
        corners = uvs if uvs is not None else (None, None, None, None)
        i = [self._add(p, n, color, uv) for p, uv in zip((a, b, c, d), corners, strict=True)]
        self._tris.add_vertices(i[0], i[1], i[2])
        self._tris.add_vertices(i[0], i[2], i[3])

    def fan(self, hub: Point3, rim: Sequence[Point3], normal: Point3, color: Color) -> None:
        """A flat fan of triangles from `hub` round the closed `rim`, its front facing `normal`:
        one vertex per point, each rim vertex shared by the two triangles that meet there."""
        centre = self._add(hub, normal, color)
        ring = [self._add(p, normal, color) for p in rim]
        for k, a in enumerate(ring):
            b = ring[(k + 1) % len(ring)]
            u = [rim[k][i] - hub[i] for i in range(3)]
            v = [rim[(k + 1) % len(rim)][i] - hub[i] for i in range(3)]
            cross = (
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            )
            front = sum(c * n for c, n in zip(cross, normal, strict=True)) >= 0
            self._tris.add_vertices(centre, *((a, b) if front else (b, a)))

    def flat_quad(self, corners: Sequence[Point2], z: float, color: Color,
                  uvs: Sequence[Point2] | None = None) -> None:  # fmt: skip
        """A horizontal quad facing up, whatever its corners' order: a strip round a bend
        tighter than its half width folds over itself, and each of its two triangles is then
        turned to face up on its own (as a tilted normal it would be shaded dark, as a culled
        back face it would leave a hole)."""
        uv: Sequence[Point2 | None] = uvs if uvs is not None else (None, None, None, None)
        k = [self._add((x, y, z), UP, color, t) for (x, y), t in zip(corners, uv, strict=True)]
        for a, b, c in ((0, 1, 2), (0, 2, 3)):
            if _area2(corners[a], corners[b], corners[c]) < 0:
                b, c = c, b
            self._tris.add_vertices(k[a], k[b], k[c])

    def wall(self, a: Point2, b: Point2, z0: float, z1: float, color: Color,
             u0: float = 0.0) -> None:  # fmt: skip
        """A vertical quad from a to b (facing right of a→b), z0..z1; texture coordinates
        in metres along the wall (from `u0`) and up, divided by the tile."""
        length = math.dist(a, b)
        tu, tv = self._tile_m
        uvs = [(u0 / tu, z0 / tv), ((u0 + length) / tu, z0 / tv),
               ((u0 + length) / tu, z1 / tv), (u0 / tu, z1 / tv)]  # fmt: skip
        self.quad((*a, z0), (*b, z0), (*b, z1), (*a, z1), color, uvs)

    def sphere(self, center: Point3, radii: Point3, color: Color,
               bumps: Sequence[float] | None = None, subdivisions: int = 1) -> None:  # fmt: skip
        """An ellipsoid from a subdivided icosahedron, smooth-shaded. `bumps` scales each
        vertex's radius (one factor per vertex, `icosphere_size(subdivisions)` of them), so a
        tree crown can be lumpy; its normals stay those of the sphere, which reads as foliage."""
        points, faces = icosphere(subdivisions)
        cx, cy, cz = center
        base = self._count
        for k, (x, y, z) in enumerate(points):
            f = bumps[k] if bumps is not None else 1.0
            self._add((cx + radii[0] * x * f, cy + radii[1] * y * f, cz + radii[2] * z * f),
                      (x, y, z), color)  # fmt: skip
        for a, b, c in faces:
            self._tris.add_vertices(base + a, base + b, base + c)

    def ribbon(self, line: Sequence[Point2], width: float, z: float, color: Color) -> None:
        """A flat strip `width` wide centred on a polyline, facing up."""
        line = densify(line, MAX_SEGMENT_M)
        left = offset_line(line, width / 2)
        right = offset_line(line, -width / 2)
        for k in range(len(line) - 1):
            self.flat_quad((right[k], right[k + 1], left[k + 1], left[k]), z, color)

    def strip(self, line: Sequence[Point2], width: float, z: float, color: Color) -> None:
        """A ribbon whose texture runs along it: u is the distance along the line, v across
        (both in metres over the tile), for kerb stones and paint that follow a curve."""
        line = densify(line, MAX_SEGMENT_M)
        left = offset_line(line, width / 2)
        right = offset_line(line, -width / 2)
        tu, tv = self._tile_m
        walked = 0.0
        for k in range(len(line) - 1):
            step = math.dist(line[k], line[k + 1])
            u0, u1, v1 = walked / tu, (walked + step) / tu, width / tv
            uvs = [(u0, 0.0), (u1, 0.0), (u1, v1), (u0, v1)]
            self.flat_quad((right[k], right[k + 1], left[k + 1], left[k]), z, color, uvs)
            walked += step

    def grid(self, bounds: tuple[float, float, float, float], z: float, color: Color,
             cells: int, shade: Callable[[float, float], float] | None = None) -> None:  # fmt: skip
        """A flat rectangle cut into cells × cells quads, facing up; `shade(x, y)` scales the
        colour at each corner. A corner is one vertex shared by the quads that meet there: its
        values were the same in each, and a vertex is lit once instead of up to four times (on
        llvmpipe the vertex shader runs on the thread that submits the scene)."""
        xmin, ymin, xmax, ymax = bounds
        dx, dy = (xmax - xmin) / cells, (ymax - ymin) / cells
        xs = [xmin + i * dx for i in range(cells)] + [xmax]  # the edge exact: a neighbour's
        ys = [ymin + j * dy for j in range(cells)] + [ymax]
        corner = [
            [self._add((x, y, z), UP, color if shade is None else _shade(color, shade(x, y)))
             for y in ys]
            for x in xs
        ]  # fmt: skip
        for i in range(cells):
            for j in range(cells):
                a, b, c, d = corner[i][j], corner[i + 1][j], corner[i + 1][j + 1], corner[i][j + 1]
                self._tris.add_vertices(a, b, c)
                self._tris.add_vertices(a, c, d)

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
        state = RenderState.make_empty()
        if self._stages:
            attrib = TextureAttrib.make()
            for stage, texture in self._stages:
                attrib = attrib.add_on_stage(stage, texture)
            state = RenderState.make(attrib)
        for extra in self._attribs:
            state = state.add_attrib(extra)
        if self.box_bounds:  # the geom's own bounds too: the node's box would hold its sphere
            geom.set_bounds_type(BoundingVolume.BT_box)
            node.set_bounds_type(BoundingVolume.BT_box)
        node.add_geom(geom, state)
        return node


def icosphere_size(subdivisions: int) -> int:
    """The number of vertices of `icosphere(subdivisions)`."""
    return 10 * 4**subdivisions + 2


def icosphere(subdivisions: int) -> tuple[list[Point3], list[tuple[int, int, int]]]:
    """Unit-sphere vertices and counter-clockwise (from outside) faces of a subdivided
    icosahedron: 20 × 4^subdivisions triangles of nearly equal size."""
    t = (1 + math.sqrt(5)) / 2
    raw = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
           (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]  # fmt: skip
    points = [_unit(p) for p in raw]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]  # fmt: skip
    for _ in range(subdivisions):
        middle: dict[tuple[int, int], int] = {}
        finer = []
        for a, b, c in faces:
            ab, bc, ca = (_midpoint(points, middle, u, v) for u, v in ((a, b), (b, c), (c, a)))
            finer += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = finer
    return points, faces


def _midpoint(points: list[Point3], middle: dict[tuple[int, int], int], a: int, b: int) -> int:
    """The index of the unit-sphere point halfway between points a and b (made once per edge)."""
    key = (min(a, b), max(a, b))
    if key not in middle:
        pa, pb = points[a], points[b]
        points.append(_unit(((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2, (pa[2] + pb[2]) / 2)))
        middle[key] = len(points) - 1
    return middle[key]


def _unit(p: tuple[float, float, float]) -> Point3:
    length = math.sqrt(p[0] ** 2 + p[1] ** 2 + p[2] ** 2)
    return (p[0] / length, p[1] / length, p[2] / length)


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
