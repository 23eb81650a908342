"""Buildings and trees: windows on every floor, doors towards the street, trees that grow as
in a park (not in rows) and never over a road; the same map always looks the same.

Documented statements checked (carlaverse/render/scene_buildings.py, textures.py,
scene_trees.py): storeys are 3 m; a window's glass runs from 0.99 m to 2.31 m above its
floor (sill at 0.9 m, head at 2.4 m, a 3 % frame); a wall with a lane within 12 m in front of
it has a door on its ground floor, other walls none; park trees are a Poisson-disc sample
with no two trunks closer than 9 m; a canopy keeps 0.3 m from every road lane.
"""

from __future__ import annotations

import itertools
import math
import random

import numpy as np
import pytest
from panda3d.core import GeomVertexReader, TextureAttrib, TextureStage

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.scene_buildings import build_buildings, storeys
from carlaverse.render.scene_trees import build_trees, plant
from carlaverse.render.textures import texture_set
from tests.render.views import NOON, Pinhole, brightness, config, runs

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H, FOV = 1280, 720, math.radians(50)
HOUSE = next(f"house-{k}" for k in range(100) if storeys(f"house-{k}") >= 5)
# 12 m square, its west wall along x = 40 (facing the camera), walked from y = 6 to y = −6
# by a counter-clockwise outline: bays of 3 m, the first from y = 6 to 3.
BLOCK = [(40.0, -6.0), (52.0, -6.0), (52.0, 6.0), (40.0, 6.0)]
STREET = m.MapLane("S_0", "road", 3.5, [(30.0, -60.0), (30.0, 60.0)], speed=13.89)
FLOOR_M = 3.0
GLASS_M = (0.99, 2.31)  # [m] above its floor


def scene(areas: list[m.MapArea], lanes: list[m.MapLane], name: str = "scenery") -> m.MapReply:
    return m.MapReply(m.SCHEMA_VERSION, name, (-60.0, -60.0, 120.0, 60.0), lanes, areas)


def render(road_map: m.MapReply, eye: Pinhole, save_shot, name: str) -> np.ndarray:
    with Renderer(config(eye.width, eye.height, math.degrees(eye.fov_h)), road_map) as r:
        r.draw(SceneFrame(0.0, (), None, NOON),
               eye=Eye(eye.x, eye.y, eye.z, eye.yaw, eye.pitch))  # fmt: skip
        img = r.images()[0]
    save_shot(name, img)
    return img


def test_facade_has_a_row_of_windows_every_3_m(save_shot) -> None:
    """Looking east at the west wall from 50 m, through the left pane of its first bay
    (y = 6 − 0.375 × 3 = 4.875): dark glass runs repeat every 3.0 m up the wall, the first
    centred 1.65 m above the ground, one per storey."""
    eye = Pinhole(-10.0, 0.0, 12.0, 0.0, 0.0, W, H, FOV)
    img = render(scene([m.MapArea(HOUSE, "building", BLOCK)], []), eye, save_shot, "facade")
    col = round(eye.project((40.0, 4.875, 0.0))[0])
    top = round(eye.project((40.0, 4.875, 24.0))[1])
    bottom = round(eye.project((40.0, 4.875, 0.0))[1])
    column = brightness(img)[:, col]
    wall = np.median(column[max(0, top) : bottom])
    glass = runs(column < 0.6 * wall)
    glass = [(a, b) for a, b in glass if top <= a and b <= bottom]
    px_per_m = eye.px_per_m(50.0)
    centres = [eye.z - ((a + b) / 2 - H / 2) / px_per_m for a, b in glass]  # [m] up the wall
    centres.sort()
    assert len(centres) >= 3, glass
    assert centres[0] == pytest.approx(sum(GLASS_M) / 2, abs=0.1)
    steps = np.diff(centres)
    assert np.allclose(steps, FLOOR_M, atol=0.05), steps
    heights = [(b - a) / px_per_m for a, b in glass]
    assert np.allclose(heights, GLASS_M[1] - GLASS_M[0], atol=0.1), heights


def _pixels(texture) -> np.ndarray:
    """A texture's RGB, rows bottom first as Panda3D keeps them."""
    data = np.frombuffer(bytes(texture.get_ram_image_as("RGB")), dtype=np.uint8)
    return data.reshape(texture.get_y_size(), texture.get_x_size(), 3).astype(int)


def test_lit_windows_are_a_texture_stage_of_their_own() -> None:
    """The contract with night lighting: facades carry the stage 'windows_emission' (mode
    M_emission) on the facade's coordinates, black but for some windows, lit only where the
    facade shows glass (dark, bluish)."""
    facades = build_buildings([m.MapArea(HOUSE, "building", BLOCK)], [], texture_set())[0]
    attrib = facades.node().get_geom_state(0).get_attrib(TextureAttrib)
    stages = {attrib.get_on_stage(k).get_name(): attrib.get_on_stage(k)
              for k in range(attrib.get_num_on_stages())}  # fmt: skip
    stage = stages["windows_emission"]
    assert stage.get_mode() == TextureStage.M_emission
    lit = _pixels(attrib.get_on_texture(stage)).max(axis=2) > 0
    colour = _pixels(attrib.get_on_texture(TextureStage.get_default()))
    glass = (colour.mean(axis=2) < 110) & (colour[..., 2] >= colour[..., 0])
    assert 0.03 < lit.mean() < 0.3  # some windows of a wall, not the wall
    assert glass[lit].mean() > 0.99


def door(img: np.ndarray) -> np.ndarray:
    """Dark brown: a wooden door (never plaster, which is bright, or glass, which is blue)."""
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > g + 15) & (g > b + 10) & (brightness(img) < 90)


@pytest.mark.parametrize(("side", "doors"), [("street", True), ("back", False)])
def test_the_ground_floor_has_a_door_towards_the_street(side, doors, save_shot) -> None:
    """A street runs 8 m in front of the west wall: its ground floor (0 … 3 m) shows a door,
    no upper floor does; the east wall, 22 m from any lane, has none."""
    x, yaw = (15.0, 0.0) if side == "street" else (77.0, math.pi)
    eye = Pinhole(x, 0.0, 1.6, yaw, 0.0, W, H, FOV)
    houses = [m.MapArea(HOUSE, "building", BLOCK)]
    img = render(scene(houses, [STREET]), eye, save_shot, f"door_{side}")
    wall_x = 40.0 if side == "street" else 52.0
    first_floor = round(eye.project((wall_x, 0.0, FLOOR_M))[1])
    found = door(img)
    if doors:
        assert found[first_floor:].sum() > 200  # about a 1.2 m × 2.2 m door at 25 m
        assert found[:first_floor].sum() == 0
    else:
        assert found.sum() == 0


PARK = m.MapArea("park", "vegetation", [(-40.0, 6.0), (40.0, 6.0), (40.0, 86.0), (-40.0, 86.0)])
ROAD = [m.MapLane("R_0", "road", 3.5, [(-60.0, 1.75), (60.0, 1.75)]),
        m.MapLane("R_1", "sidewalk", 2.0, [(-60.0, 4.5), (60.0, 4.5)])]  # fmt: skip


def test_park_trees_are_scattered_not_in_rows() -> None:
    """Nearest-neighbour distances of a grid are all equal; a Poisson disc's vary, none below
    its 9 m; and the sizes of the canopies vary too."""
    trees = plant([PARK], ROAD, seed=7)
    assert len(trees) > 40
    xy = np.array([(t.x, t.y) for t in trees])
    gaps = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(gaps, np.inf)
    nearest = gaps.min(axis=1)
    assert nearest.min() >= 9.0 - 1e-9
    assert nearest.std() / nearest.mean() > 0.05
    rows = {round(t.y, 1) for t in trees}
    assert len(rows) > 0.9 * len(trees)  # hardly two trees share a row
    assert np.std([t.reach_m for t in trees]) > 0.2
    assert plant([PARK], ROAD, seed=7) == trees  # the same seed plants the same trees
    assert plant([PARK], ROAD, seed=8) != trees


def _segment_gap(x: float, y: float, lane: m.MapLane) -> float:
    """Distance from a point to a lane's surface, by brute force over its segments."""
    best = math.inf
    for (ax, ay), (bx, by) in itertools.pairwise(lane.centerline):
        dx, dy = bx - ax, by - ay
        s = max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(x - ax - s * dx, y - ay - s * dy) - lane.width / 2)
    return best


def test_no_canopy_reaches_over_a_road() -> None:
    """Every tree's canopy (all of its crowns' vertices, from the mesh itself) lies within its
    reach of the trunk, and that reach ends 0.3 m short of the road lane."""
    trees = plant([PARK], ROAD, seed=7)
    for tree in trees:
        assert _segment_gap(tree.x, tree.y, ROAD[0]) >= tree.reach_m + 0.3 - 1e-6
    for tree in random.Random(1).sample(trees, 10):
        (mesh,) = build_trees([tree], seed=3)
        reader = GeomVertexReader(mesh.node().get_geom(0).get_vertex_data(), "vertex")
        while not reader.is_at_end():
            v = reader.get_data3()
            assert math.hypot(v[0] - tree.x, v[1] - tree.y) <= tree.reach_m + 1e-4


def test_a_tree_on_a_road_is_not_planted() -> None:
    """A park drawn over the road keeps its trees off it (and their canopies clear)."""
    over = m.MapArea("over", "vegetation", [(-40.0, -30.0), (40.0, -30.0), (40.0, 30.0),
                                             (-40.0, 30.0)])  # fmt: skip
    trees = plant([over], ROAD, seed=5)
    assert trees and all(_segment_gap(t.x, t.y, ROAD[0]) >= t.reach_m + 0.3 - 1e-6 for t in trees)


def test_same_map_same_pixels_and_another_map_other_trees(save_shot) -> None:
    eye = Pinhole(0.0, -20.0, 8.0, math.pi / 2, math.radians(15), 480, 270, math.radians(70))
    areas = [PARK, m.MapArea(HOUSE, "building", [(50.0, 10.0), (62.0, 10.0), (62.0, 22.0),
                                                 (50.0, 22.0)])]  # fmt: skip
    first = render(scene(areas, ROAD), eye, save_shot, "same_1")
    again = render(scene(areas, ROAD), eye, save_shot, "same_2")
    other = render(scene(areas, ROAD, name="elsewhere"), eye, save_shot, "other")
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)  # the map's name seeds where trees grow
