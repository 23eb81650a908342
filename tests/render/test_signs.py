"""Traffic signs from the map: where they stand, and what a driver sees there.

The rules are the ones `carlaverse/render/signs.py` documents: a speed-limit sign 6 m into an
edge whose limit differs from the edge leading into it (or that traffic enters the map by),
showing SUMO's lane speed × 3.6 in km/h; a stop sign 1 m before the end of an edge whose
lanes must stop, a give-way sign where they must yield; the pole 0.7 m right of the road's
edge, the face (0.6 m across, its lower edge 2.0 m up: VwV-StVO size 2) turned towards the
traffic. Shapes and colours are the StVO's: a red ring round a white disc with the number in
black (Zeichen 274), a red octagon (206), a white triangle point down in a red rim (205).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image, ImageDraw, ImageFont

from carlaverse import messages as m
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.signs import place_signs
from carlaverse.traffic.mapdata import build_map_reply, read_net
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario
from tests.render.views import NOON, Pinhole, config
from tests.traffic.test_lane_rules import EDGES, NODES, SCENARIO

W, H, FOV = 640, 360, math.radians(40)
HALF = 1.75  # [m] half a lane
SETBACK = 0.7  # [m] road edge to pole
FACE_Z = 2.0 + 0.3  # [m] the middle of a 0.6 m face whose lower edge is 2.0 m up


def road(edge: str, x0: float, x1: float, speed: float, successors: list[str] | None = None,
         right_of_way: str = "") -> m.MapLane:  # fmt: skip
    return m.MapLane(f"{edge}_0", "road", 2 * HALF, [(x0, -HALF), (x1, -HALF)], speed=speed,
                     right_of_way=right_of_way, successors=successors or [])  # fmt: skip


def street(*lanes: m.MapLane, name: str = "signs") -> m.MapReply:
    return m.MapReply(m.SCHEMA_VERSION, name, (-50.0, -50.0, 300.0, 50.0), list(lanes))


# A at 50 km/h leads into B at 30 km/h, B into C, also at 30.
CHAIN = [road("A", 0, 100, 13.89, ["B_0"]), road("B", 110, 200, 8.33, ["C_0"]),
         road("C", 210, 290, 8.33)]  # fmt: skip


def test_speed_signs_stand_where_the_limit_changes() -> None:
    signs = {s.edge: s for s in place_signs(CHAIN) if s.kind == "speed"}
    assert set(signs) == {"A", "B"}  # A: where traffic enters; B: 50 → 30; C: still 30
    assert (signs["A"].kmh, signs["B"].kmh) == (50, 30)  # 13.89 and 8.33 m/s × 3.6
    b = signs["B"]  # 6 m into B, right of its lane's right edge (y = −3.5) by 0.7 m
    assert (b.x, b.y) == pytest.approx((116.0, -2 * HALF - SETBACK))
    assert math.cos(b.facing) == pytest.approx(-1.0)  # facing west, at the eastbound traffic


def test_signs_through_sumo_follow_the_junctions(tmp_path) -> None:
    """The lane-rules network (tests/traffic/test_lane_rules.py) through netconvert: stop at
    the priority_stop side road, give way at the priority side road, stop on every approach
    of the allway_stop, nothing at the light; 30 where the street slows from 50, 80 where it
    speeds up to 22.22 m/s."""
    for name, text in (
        ("rules.nod.xml", NODES),
        ("rules.edg.xml", EDGES),
        ("rules.yaml", SCENARIO),
    ):
        (tmp_path / name).write_text(text, encoding="utf-8")
    built = build_map(load_scenario(tmp_path / "rules.yaml"), tmp_path / "cache")
    lanes = build_map_reply(read_net(built.net), "lane-rules").lanes
    signs = place_signs(lanes)
    ends = {(s.edge, s.kind) for s in signs if s.kind != "speed"}
    assert ends == {("SNS", "stop"), ("PNP", "yield"), ("ANA", "stop"), ("SA", "stop"),
                    ("TA", "stop")}  # fmt: skip
    limits = {s.edge: s.kmh for s in signs if s.kind == "speed"}
    assert limits["PS"] == 30 and limits["TE"] == 80 and limits["AT"] == 50
    assert "SA" not in limits  # 30 after 30


def render(road_map: m.MapReply, eye: Pinhole, save_shot, name: str) -> np.ndarray:
    with Renderer(config(eye.width, eye.height, math.degrees(eye.fov_h)), road_map) as r:
        r.draw(SceneFrame(0.0, (), None, NOON),
               eye=Eye(eye.x, eye.y, eye.z, eye.yaw, eye.pitch))  # fmt: skip
        img = r.images()[0]
    save_shot(name, img)
    return img


def red(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > 110) & (r > 2 * g) & (r > 2 * b)


def test_a_speed_sign_shows_at_its_place_with_the_lanes_number(save_shot) -> None:
    """Driving east on B, 10 m before its sign at (116, −4.2): the red ring is centred where
    the face's middle (116 − 0.05, −4.2, 2.3) projects, 0.6 m across, and the digits inside
    match '30' better than any other limit drawn in the same font."""
    eye = Pinhole(106.0, -HALF, 1.2, 0.0, 0.0, W, H, FOV)
    img = render(street(*CHAIN), eye, save_shot, "speed_sign")
    rows, cols = np.nonzero(red(img))
    assert rows.size > 200, "no red ring in view"
    col, row = eye.project((116.0 - 0.05, -2 * HALF - SETBACK, FACE_Z))
    assert cols.mean() == pytest.approx(col, abs=2.0) and rows.mean() == pytest.approx(row, abs=2.0)
    diameter = 0.6 * eye.px_per_m(10.0 - 0.05)
    assert cols.max() + 1 - cols.min() == pytest.approx(diameter, abs=3.0)
    assert rows.max() + 1 - rows.min() == pytest.approx(diameter, abs=3.0)
    ink = _digits(img, col, row, diameter)
    scores = {n: _overlap(ink, n) for n in (10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 120)}
    assert max(scores, key=scores.get) == 30, scores


def _digits(img: np.ndarray, col: float, row: float, diameter: float) -> np.ndarray:
    """The dark pixels inside the ring's white disc, cropped to their bounding box."""
    r = 0.34 * diameter  # inside the ring (its inner radius is 0.375 of the diameter)
    box = img[round(row - r) : round(row + r), round(col - r) : round(col + r)].astype(int)
    ys, xs = np.mgrid[: box.shape[0], : box.shape[1]]
    disc = np.hypot(ys + 0.5 - r, xs + 0.5 - r) < r
    dark = (box.mean(axis=2) < 110) & disc
    ys, xs = np.nonzero(dark)
    assert ys.size > 20, "no number on the sign"
    return dark[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]


def _overlap(ink: np.ndarray, number: int) -> float:
    """Intersection over union of the ink with `number` drawn (Pillow's default font) at
    the ink's size."""
    font = ImageFont.load_default(size=64)
    probe = Image.new("L", (200, 100), 0)
    ImageDraw.Draw(probe).text((10, 10), str(number), font=font, fill=255)
    glyphs = np.asarray(probe) > 127
    ys, xs = np.nonzero(glyphs)
    glyphs = glyphs[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
    h, w = ink.shape
    scaled = np.asarray(Image.fromarray(glyphs.astype(np.uint8) * 255).resize((w, h))) > 127
    return float((scaled & ink).sum() / max(1, (scaled | ink).sum()))


@pytest.mark.parametrize("rule", ["stop", "yield", "major"])
def test_a_stop_or_give_way_sign_stands_where_the_junction_says_so(rule, save_shot) -> None:
    """A lane ending at x = 100 whose right of way is `rule`: its sign 1 m before the end,
    0.7 m beyond the road's edge (pole at (99, −4.2)), seen from 15 m back. A stop sign is an
    octagon: red reaches the middle of each side of its bounding square but not the corners;
    a give-way triangle has its point down, so its red lies mostly in the upper half; the main
    road gets no sign at all."""
    eye = Pinhole(84.0, -HALF, 1.2, 0.0, 0.0, W, H, FOV)
    img = render(
        street(road("J", 0, 100, 13.89, right_of_way=rule)), eye, save_shot, f"sign_{rule}"
    )
    mask = red(img)
    if rule == "major":
        assert mask.sum() == 0
        return
    rows, cols = np.nonzero(mask)
    assert rows.size > 100, f"no {rule} sign in view"
    col, _ = eye.project((99.0 - 0.05, -2 * HALF - SETBACK, 2.0))
    assert (cols.min() + cols.max() + 1) / 2 == pytest.approx(col, abs=2.0)
    box = mask[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
    h, w = box.shape
    if rule == "stop":
        k = max(2, round(0.1 * min(h, w)))
        corners = [box[:k, :k], box[:k, -k:], box[-k:, :k], box[-k:, -k:]]
        assert all(c.mean() < 0.2 for c in corners)
        assert box[h // 2, :k].any() and box[h // 2, -k:].any() and box[:k, w // 2].any()
    else:
        upper, lower = box[: h // 2].sum(), box[h // 2 :].sum()
        assert upper > 1.5 * lower
        assert box[-1].sum() < 0.2 * w  # a point at the bottom, not an edge
