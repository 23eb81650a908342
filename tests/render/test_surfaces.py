"""Road surfaces in real rendered pixels: where the paint is, how it is dashed, the kerb's face.

Every scene is a synthetic map whose geometry is known, seen through a pinhole worked out by
hand (tests/render/views.py). The statements checked are the ones the marking rules are
documented by (carlaverse/render/scene_markings.py, after Germany's RMS): a line is 0.12 m
wide and lies inside the lane whose edge it marks; a lane line is dashed 3 m on, 6 m off up to
50 km/h where cars may change lanes both ways, solid where they may not; oncoming lanes are
split by one centre line 0.12 m wide; zebra bars are 0.5 m with 0.5 m gaps along the walk;
a sidewalk stands 0.12 m above the road on a vertical kerb.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from tests.render.views import NOON, Pinhole, brightness, config, runs

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H, FOV = 1280, 720, math.radians(60)
TOWN = 13.89  # [m/s] 50 km/h: the dashes are 3 m on, 6 m off
START = -100.0  # [m] where the lanes begin (dashes are laid from a lane's start)
PAINT_TOP = 0.04  # [m] about where paint lies (a few cm up; the error is far below a pixel)
LINE_M = 0.12  # [m] narrow line
# Straight down from 20 m, heading north: east is to the right, north up the image.
ABOVE = Pinhole(20.0, 0.0, 20.0, math.pi / 2, math.pi / 2, W, H, FOV)


def lane(lane_id: str, y: float, kind: str = "road", reverse: bool = False, **rules) -> m.MapLane:
    line = [(START, y), (300.0, y)]
    return m.MapLane(lane_id, kind, 3.5, line[::-1] if reverse else line, speed=TOWN, **rules)


def road_map(lanes: list[m.MapLane], name: str = "surfaces") -> m.MapReply:
    return m.MapReply(m.SCHEMA_VERSION, name, (-100.0, -60.0, 300.0, 60.0), lanes)


def render(road: m.MapReply, eye: Pinhole, save_shot, name: str) -> np.ndarray:
    with Renderer(config(eye.width, eye.height, math.degrees(eye.fov_h)), road) as r:
        r.draw(SceneFrame(0.0, (), None, NOON),
               eye=Eye(eye.x, eye.y, eye.z, eye.yaw, eye.pitch))  # fmt: skip
        img = r.images()[0]
    save_shot(name, img)
    return img


def row_of(y: float) -> float:
    return ABOVE.project((ABOVE.x, y, PAINT_TOP))[1]


def col_of(x: float) -> float:
    return ABOVE.project((x, ABOVE.y, PAINT_TOP))[0]


def paint_mask(img: np.ndarray, asphalt: float) -> np.ndarray:
    """White paint: bright, grey, and far brighter than the asphalt it is on."""
    spread = img.astype(int).max(axis=2) - img.astype(int).min(axis=2)
    return (brightness(img) > max(140.0, 2.0 * asphalt)) & (spread < 50)


def asphalt_level(img: np.ndarray, y: float) -> float:
    return float(np.median(brightness(img)[round(row_of(y)), 100:-100]))


def band(y0: float, y1: float) -> slice:
    """Rows wholly inside the band between two northings (both edges' rows excluded)."""
    r0, r1 = sorted((row_of(y0), row_of(y1)))
    return slice(math.ceil(r0) + 1, math.floor(r1) - 1)


def test_edge_line_is_white_and_lies_at_the_lanes_outer_edge(save_shot) -> None:
    """A lane with nothing on its right: its edge line spans y = −3.50 … −3.38 (lane E_0
    centred on −1.75, 3.5 m wide); white there, asphalt just inside, no paint just outside."""
    img = render(road_map([lane("E_0", -1.75), lane("E_1", 1.75)]), ABOVE, save_shot, "edge")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    cols = slice(100, W - 100)
    assert paint[band(-3.5, -3.5 + LINE_M), cols].mean() > 0.95
    inside, outside = band(-3.30, -3.0), band(-3.9, -3.58)
    assert paint[inside, cols].mean() < 0.01 and paint[outside, cols].mean() < 0.01
    # the line's rows, found from the pixels, against the projected edge (±1.5 px)
    lit = np.flatnonzero(paint[:, W // 2])
    lit = lit[(lit > row_of(-3.0)) & (lit < row_of(-4.0))]
    assert lit.min() == pytest.approx(row_of(-3.5 + LINE_M), abs=1.5)
    assert lit.max() + 1 == pytest.approx(row_of(-3.5), abs=1.5)


def test_a_lane_line_is_dashed_3_m_on_6_m_off_where_lanes_may_be_changed(save_shot) -> None:
    """Two lanes one way, changes allowed: dashes laid from the lanes' start at x = −100, so
    paint covers x ∈ [−100 + 9k, −97 + 9k]; in view (x 8.5 … 31.5): [8, 11], [17, 20], [26, 29]."""
    img = render(road_map([lane("E_0", -1.75), lane("E_1", 1.75)]), ABOVE, save_shot, "dashed")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    seen = runs(paint[band(-LINE_M / 2, LINE_M / 2)].mean(axis=0) > 0.5)
    want = [(col_of(x0), col_of(x1)) for x0, x1 in ((8, 11), (17, 20), (26, 29))]
    want = [(max(0.0, a), min(float(W), b)) for a, b in want]
    assert len(seen) == len(want), (seen, want)
    for (a, b), (wa, wb) in zip(seen, want, strict=True):
        assert a == pytest.approx(wa, abs=2.0) and b == pytest.approx(wb, abs=2.0)
    px_per_m = ABOVE.px_per_m(ABOVE.z - PAINT_TOP)
    full = [(a, b) for a, b in seen if a > 0 and b < W]  # dashes not cut by the frame
    assert full and all((b - a) / px_per_m == pytest.approx(3.0, abs=0.05) for a, b in full)
    gaps = [(c - b) / px_per_m for (_, b), (c, _) in itertools.pairwise(seen)]
    assert gaps and all(g == pytest.approx(6.0, abs=0.05) for g in gaps)


def test_a_lane_line_is_solid_where_no_car_may_change(save_shot) -> None:
    lanes = [lane("E_0", -1.75, change_left=False), lane("E_1", 1.75, change_right=False)]
    img = render(road_map(lanes), ABOVE, save_shot, "solid")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    assert paint[band(-LINE_M / 2, LINE_M / 2), 20 : W - 20].mean() > 0.95


def test_one_way_permission_is_a_solid_line_beside_a_dashed_one(save_shot) -> None:
    """Only the left lane's cars may cross (to the right): the solid line on the right lane's
    side (y −0.18 … −0.06), the dashes on the left lane's side (y 0.06 … 0.18)."""
    lanes = [lane("E_0", -1.75, change_left=False), lane("E_1", 1.75)]
    img = render(road_map(lanes), ABOVE, save_shot, "one_sided")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    solid = paint[band(-0.18, -0.06), 20 : W - 20].mean(axis=0)
    dashed = paint[band(0.06, 0.18), 20 : W - 20].mean(axis=0)
    assert solid.min() > 0.9
    assert 0.25 < (dashed > 0.5).mean() < 0.45  # 3 m of every 9 m


def test_oncoming_lanes_share_one_centre_line(save_shot) -> None:
    """Oncoming lanes without a SUMO neigh (no overtaking): one solid line 0.12 m wide centred
    on the boundary; with a neigh, the same line dashed."""
    pair = [lane("A_0", -1.75), lane("B_0", 1.75, reverse=True)]
    img = render(road_map(pair), ABOVE, save_shot, "centre_solid")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    column = np.flatnonzero(paint[:, W // 2])
    column = column[(column > row_of(1.0)) & (column < row_of(-1.0))]
    assert column.min() == pytest.approx(row_of(LINE_M / 2), abs=1.5)
    assert column.max() + 1 == pytest.approx(row_of(-LINE_M / 2), abs=1.5)
    assert paint[band(-0.04, 0.04), 20 : W - 20].mean() > 0.95
    overtake = [lane("A_0", -1.75, opposite="B_0"), lane("B_0", 1.75, reverse=True, opposite="A_0")]
    img = render(road_map(overtake), ABOVE, save_shot, "centre_dashed")
    paint = paint_mask(img, asphalt_level(img, -1.0))
    share = (paint[band(-0.04, 0.04), 20 : W - 20].mean(axis=0) > 0.5).mean()
    assert 0.25 < share < 0.45


def test_a_zebra_has_bars_across_the_crossing(save_shot) -> None:
    """A crossing 4 m wide walked from y = −4 to 4 at x = 20: bars 0.5 m on, 0.5 m off along
    the walk from its start, each spanning the crossing's width (x 18 … 22)."""
    zebra = m.MapLane("c_0", "crossing", 4.0, [(20.0, -4.0), (20.0, 4.0)])
    img = render(road_map([zebra]), ABOVE, save_shot, "zebra")
    gap = brightness(img)[round(row_of(-3.25)), round(col_of(20.0))]  # asphalt between bars
    paint = paint_mask(img, gap)
    seen = runs(paint[:, round(col_of(20.0))])
    want = [(row_of(y + 0.5), row_of(y)) for y in np.arange(-4.0, 4.0, 1.0)]
    assert len(seen) == len(want) == 8
    for (a, b), (wa, wb) in zip(sorted(seen), sorted(want), strict=True):
        assert a == pytest.approx(wa, abs=2.0) and b == pytest.approx(wb, abs=2.0)
    across = paint[round(row_of(-3.75)), round(col_of(18.2)) : round(col_of(21.8))]
    assert across.mean() > 0.95  # the first bar spans the crossing's width


def test_the_kerb_is_a_step_with_a_face_down_to_the_road(save_shot) -> None:
    """A sidewalk right of the road, its edge (the kerb) along y = −1.75, its top 0.12 m up.
    From the driver's eye (1.2 m) at a forward distance d, the kerb line appears between the
    rows of (d, −1.75, 0.12) and of (d, −1.75, 0.05) — the top of the road's edge line, which
    runs along the kerb's foot in front of it: a band of kerb-stone face, grey and brighter
    than asphalt (where a flat slab would show the green ground beneath it)."""
    eye = Pinhole(0.0, 0.0, 1.2, 0.0, 0.0, W, H, math.radians(90))
    road = m.MapLane("R_1", "road", 3.5, [(START, 0.0), (300.0, 0.0)], speed=TOWN)
    walk = m.MapLane("R_0", "sidewalk", 3.0, [(START, -3.25), (300.0, -3.25)], speed=TOWN)
    img = render(road_map([walk, road]), eye, save_shot, "kerb")
    asphalt = float(brightness(img)[round(eye.project((5.0, 0.5, 0.02))[1]), W // 2 - 20])
    face_pixels = []
    for d in (4.0, 5.0, 6.0, 8.0):
        col, top = eye.project((d, -1.75, 0.12))
        _, bottom = eye.project((d, -1.75, 0.05))
        assert bottom - top > 5  # the band is wide enough to judge
        face_pixels.append(img[math.ceil(top) + 1 : math.floor(bottom) - 1, round(col)])
    face = np.concatenate(face_pixels).astype(int)
    grey = (np.abs(face[:, 0] - face[:, 1]) < 20) & (np.abs(face[:, 1] - face[:, 2]) < 20)
    brighter = face.mean(axis=1) > asphalt + 10
    assert (grey & brighter).mean() > 0.9, (face.mean(axis=0), asphalt)


def test_same_map_same_pixels(save_shot) -> None:
    lanes = [lane("E_0", -1.75), lane("E_1", 1.75)]
    first = render(road_map(lanes), ABOVE, save_shot, "same_a")
    second = render(road_map(lanes), ABOVE, save_shot, "same_b")
    assert np.array_equal(first, second)


def test_a_lane_round_a_tight_bend_faces_up_everywhere(save_shot) -> None:
    """A right turn through a junction as SUMO shapes it (town's :B1_6_0, 3.2 m wide, its
    last segment 0.23 m long at a sharp angle): its inner edge folds over itself. A flat road
    under one sun is lit the same everywhere: no part of it may come out dark (a fold turned
    upside down is shaded as if facing the ground) or show the grass beneath (culled)."""
    shape = [(1.6, -7.2), (1.95, -4.75), (3.0, -3.0), (3.2, -2.88)]
    turn = m.MapLane(":J_6_0", "road", 3.2, shape)
    eye = Pinhole(2.5, -4.5, 9.0, math.pi / 2, math.pi / 2, 640, 640, math.radians(50))
    grass = render(road_map([]), eye, save_shot, "bend_without")
    img = render(road_map([turn]), eye, save_shot, "bend")
    road = np.abs(img.astype(int) - grass.astype(int)).max(axis=2) > 12
    level = brightness(img)
    assert road.sum() > 5000
    dark = road & (level < 0.6 * np.median(level[road]))  # grain varies by ±25 % at most
    assert dark.sum() < 10, dark.sum()
