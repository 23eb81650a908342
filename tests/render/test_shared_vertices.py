"""A wheel's rim disc is a fan whose triangles share their vertices (`shapes.disc_x`): a
regular polygon of n sides is n triangles on n + 1 points (its centre and its corners), each
facing the side asked for; before, each triangle was a quad of four vertices of its own."""

from __future__ import annotations

import pytest
from panda3d.core import GeomVertexReader, Vec3

from carlaverse.render.meshes import MeshBuilder
from carlaverse.render.shapes import disc_x


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_disc_is_n_triangles_on_n_plus_one_vertices_facing_its_side(side: float) -> None:
    sides = 10
    mesh = MeshBuilder("disc")
    disc_x(mesh, (0.3, 0.0, 0.0), (0.6, 0.6), side, (0.5, 0.5, 0.5, 1.0), sides=sides)
    geom = mesh.node().get_geom(0)
    data = geom.get_vertex_data()
    assert data.get_num_rows() == sides + 1
    tris = geom.get_primitive(0).decompose()
    assert tris.get_num_primitives() == sides
    reader = GeomVertexReader(data, "vertex")
    points = []
    for row in range(data.get_num_rows()):
        reader.set_row(row)
        points.append(Vec3(reader.get_data3()))
    for k in range(sides):
        a, b, c = (points[tris.get_vertex(3 * k + i)] for i in range(3))
        front = (b - a).cross(c - a)  # counter-clockwise seen from the front
        assert front.dot(Vec3(side, 0.0, 0.0)) > 0.0
