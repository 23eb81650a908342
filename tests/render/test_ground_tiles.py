"""The ground is drawn in tiles (`scene_areas.ground`): together they cover the ground once,
each quad corner is one vertex, and a camera culls the tiles it cannot see instead of lighting
every vertex of the ground each frame (what the cpu preset paid on llvmpipe)."""

from __future__ import annotations

import math

from panda3d.core import Camera, NodePath, PerspectiveLens

from carlaverse.render.scene_areas import GROUND_CELLS, GROUND_MARGIN_M, GROUND_TILES, ground
from carlaverse.render.textures import texture_set

BOUNDS = (-100.0, -50.0, 100.0, 50.0)


def tiles() -> list[NodePath]:
    return [NodePath(tile.node()) for tile in ground(BOUNDS, texture_set(plain=True))]


def test_the_tiles_cover_the_ground_once() -> None:
    """The ground spans the map and the margin around it; the tiles' areas add up to that
    rectangle's (no gap, no overlap), and each is a grid of cells sharing their corners:
    (c + 1)² vertices and 2c² triangles for c cells a side."""
    m = GROUND_MARGIN_M
    xmin, ymin, xmax, ymax = BOUNDS[0] - m, BOUNDS[1] - m, BOUNDS[2] + m, BOUNDS[3] + m
    nodes = tiles()
    boxes = [node.get_tight_bounds() for node in nodes]
    assert min(lo.x for lo, _ in boxes) == xmin and max(hi.x for _, hi in boxes) == xmax
    assert min(lo.y for lo, _ in boxes) == ymin and max(hi.y for _, hi in boxes) == ymax
    area = sum((hi.x - lo.x) * (hi.y - lo.y) for lo, hi in boxes)
    assert math.isclose(area, (xmax - xmin) * (ymax - ymin), rel_tol=1e-6)
    c = GROUND_CELLS // GROUND_TILES
    for node in nodes:
        geom = node.node().get_geom(0)
        assert geom.get_vertex_data().get_num_rows() == (c + 1) ** 2
        assert geom.get_primitive(0).get_num_primitives() == 2 * c * c


def test_the_tiles_behind_the_eye_are_culled() -> None:
    """An eye 5 m east of the map's middle looking east (+x) sees nothing west of itself:
    every tile lying wholly at x <= 0 is outside its view frustum, whatever the lens (one
    mesh for the whole ground, as before, was always in view)."""
    root = NodePath("world")
    nodes = tiles()
    for node in nodes:
        node.reparent_to(root)
    lens = PerspectiveLens()
    lens.set_fov(90.0, 60.0)
    lens.set_near_far(0.1, 1000.0)
    eye = root.attach_new_node(Camera("eye", lens))
    eye.set_pos(5.0, 0.0, 1.2)
    eye.set_h(-90.0)  # Panda3D's camera looks along +y; H -90 turns it to +x
    frustum = lens.make_bounds()
    culled, behind = 0, 0
    for node in nodes:
        hi = node.get_tight_bounds()[1]
        behind += hi.x <= 0.0
        box = node.get_bounds().make_copy()
        box.xform(node.get_mat(eye))
        culled += not frustum.contains(box)
    assert behind == GROUND_TILES * GROUND_TILES // 2  # the map is centred on x = 0
    assert culled >= behind
