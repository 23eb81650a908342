"""Mirrors in real pixels: a car placed behind shows in the rear-view mirror, on the side a
mirror puts it, and a car in the next lane behind on the left shows in the left door mirror.

Which side (worked out here, not taken from the code): the driver faces forward (+x, left
+y). A plane mirror in front of them reverses front and back but not left and right: light
from a point behind and to the driver's left reaches the eye from the mirror's left part,
just as a point to the left of a window shows in the window's left part. So a car behind
and to the left shows in the left half of the rear-view mirror as the driver sees it (and a
camera looking backwards sees that car in the right half of its own picture: its right is
the vehicle's left, forward × up = (−1, 0, 0) × (0, 0, 1) = (0, 1, 0)).

What a mirror shows: a flat mirror of width w at distance d from the eye shows the angle it
subtends, 2·atan(w/2d). The rear-view mirror below (0.24 m at 0.64 m) shows ±10.6° about
straight back; a car 12 m behind it and 1.2 m aside lies 5.5° off that axis.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.frame import ActorDraw, SceneFrame
from carlaverse.render.own_config import Cockpit, Hud, Mirror, OwnView
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig, layout
from tests.render.support import changed

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H = 480, 270
DRIVER = HeadPosition(x=0.1, y=0.37, z=1.2)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)
REAR = Mirror(name="rear", at=(0.65, 0.05, 1.30), size=(0.24, 0.07), yaw_deg=180.0)
LEFT = Mirror(name="left", at=(0.85, 1.0, 1.0), size=(0.16, 0.11), yaw_deg=172.0, fov_deg=18.0)
OWN = OwnView(cockpit=Cockpit(), mirrors=(REAR, LEFT))
CONFIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=W, height=H), fov_deg=90, head=DRIVER),
    own=OWN,
)


def car(actor_id: str, x: float, y: float, ego: bool = False) -> ActorDraw:
    e = m.KIND_EXTENTS["car"]
    return ActorDraw(actor_id, "car", x, y, 0.0, 0.0, e.length, e.width, e.height, ego=ego)


def riding(*others: ActorDraw, config: RenderConfig = CONFIG) -> np.ndarray:
    with Renderer(config, None) as r:
        r.draw(SceneFrame(0.0, (car("me", 0.0, 0.0, ego=True), *others), None, NOON),
               follow="me")  # fmt: skip
        return r.images()[0]


def glass_box(mirror: Mirror, margin_px: int = 2) -> tuple[slice, slice]:
    """Rows and columns of the glass in the driver's view: its corners, a rectangle facing the
    eye (its right edge along the eye's line of sight × up), through the rig's pinhole."""
    cam = layout(CONFIG.camera).cameras[0]
    eye = np.array([DRIVER.x, DRIVER.y, DRIVER.z])
    at = np.array(mirror.at)
    sight = (at - eye) / np.linalg.norm(at - eye)
    right = np.cross(sight, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, sight)
    cols, rows = [], []
    w, h = mirror.size
    for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        f, left, rise = at + a * right * w / 2 + b * up * h / 2 - eye
        cols.append((1 - (left / f) / math.tan(cam.fov_h / 2)) / 2 * W)
        rows.append((1 - (rise / f) / math.tan(cam.fov_v / 2)) / 2 * H)
    return (slice(math.ceil(min(rows)) + margin_px, math.floor(max(rows)) - margin_px),
            slice(math.ceil(min(cols)) + margin_px, math.floor(max(cols)) - margin_px))  # fmt: skip


@pytest.fixture(scope="module")
def behind() -> dict[str, np.ndarray]:
    return {
        "nobody": riding(),
        "left": riding(car("other", -12.0, 1.25)),
        "right": riding(car("other", -12.0, -1.15)),
        "lane_left": riding(car("other", -15.0, 3.5)),
        "lane_right": riding(car("other", -15.0, -3.5)),
    }


def test_a_car_behind_shows_in_the_rear_view_mirror_on_its_side(behind, save_shot) -> None:
    save_shot("mirror_behind_left", behind["left"])
    rows, cols = glass_box(REAR)
    middle = (cols.stop - cols.start) / 2
    for side in ("left", "right"):
        seen = changed(behind[side], behind["nobody"])
        inside = seen[rows, cols]
        assert inside.sum() >= 20, f"the car behind {side} is not in the mirror"
        centre = np.nonzero(inside)[1].mean()
        assert (centre < middle) == (side == "left"), (side, centre, middle)
        outside = seen.copy()
        for mirror in (REAR, LEFT):  # the glass and its edge pixels
            outside[glass_box(mirror, margin_px=-3)] = False
        assert outside.sum() == 0, "a car behind is seen outside the mirrors"


def test_a_car_in_the_left_lane_behind_shows_in_the_left_door_mirror(behind) -> None:
    rows, cols = glass_box(LEFT)
    assert changed(behind["lane_left"], behind["nobody"])[rows, cols].sum() >= 10
    assert changed(behind["lane_right"], behind["nobody"])[rows, cols].sum() == 0


def test_the_whole_glass_shows_the_view_behind() -> None:
    """A truck's back, 3.4 m tall and 2.5 m wide, 8 m behind, fills the rear-view mirror's
    field (±10.6° across, ±3.1° up and down: ±0.47 m about the mirror's height there): every
    part of the glass changes, its top third as well as its bottom third."""
    e = m.KIND_EXTENTS["truck"]
    truck = ActorDraw("truck", "truck", -8.0 - e.length / 2, 0.05, 0.0, 0.0, e.length, e.width,
                      e.height)  # fmt: skip
    rows, cols = glass_box(REAR)
    seen = changed(riding(truck), riding())[rows, cols]
    seen = seen[:, seen.shape[1] // 4 : 3 * seen.shape[1] // 4]  # the glass's middle: seen at
    third = seen.shape[0] // 3  # 30° to the right it leans, and the box holds its housing too
    for name, part in (("top", seen[:third]), ("bottom", seen[-third:])):
        assert part.mean() > 0.6, (name, part.mean())


def test_mirrors_are_the_same_picture_for_the_same_frame() -> None:
    own = OwnView(cockpit=Cockpit(), mirrors=(REAR, LEFT), hud=Hud())
    config = RenderConfig(output="offscreen", camera=CONFIG.camera, own=own)
    first = riding(car("other", -12.0, 1.25), config=config)
    again = riding(car("other", -12.0, 1.25), config=config)
    assert np.array_equal(first, again)
