"""The first-person renderer draws each eye with its own asymmetric frustum (an off-axis
Panda3D lens): a car dead ahead appears where the eye's frustum puts it, not in the middle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.frame import SceneFrame
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, XrEye, XrRig

pytest.importorskip("panda3d", reason="needs the render extra: pip install -e '.[render]'")
pytestmark = pytest.mark.usefixtures("offscreen_gl")

from tests.render.conftest import offscreen_gl, save_shot  # noqa: E402, F401  (fixtures)
from tests.render.support import car, changed  # noqa: E402

EYE_PX = 300
EYE_Z = 1.65  # [m]
IPD = 0.063  # [m]
# tan(left) = −1, tan(right) = 0.5, tan(up) = 0.5, tan(down) = −1 for the left eye; mirrored.
T = math.degrees(math.atan(0.5))
LEFT_EYE = XrEye(left_deg=-45.0, right_deg=T, up_deg=T, down_deg=-45.0)
RIGHT_EYE = XrEye(left_deg=-T, right_deg=45.0, up_deg=T, down_deg=-45.0)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)


def column(tan_right: float, tan_left_edge: float) -> float:
    """Pixel column of a direction (tangent to the right of the axis) in a 1.5-wide eye."""
    return (tan_right - tan_left_edge) / 1.5 * EYE_PX


def test_each_eye_sees_a_car_ahead_where_its_frustum_puts_it(save_shot) -> None:  # noqa: F811
    from carlaverse.render.renderer import Renderer

    rig = XrRig(eye_resolution=Resolution(width=EYE_PX, height=EYE_PX), left_eye=LEFT_EYE,
                right_eye=RIGHT_EYE, ipd_m=IPD, head=HeadPosition(z=EYE_Z))  # fmt: skip
    me = car("me", 0.0, 0.0, kind="pedestrian", ego=True)  # facing east
    ahead = car("ahead", 20.0, 0.0)
    # flat: the camera maths is judged on the silhouette, and a shaded car also shadows the road
    with Renderer(RenderConfig(output="offscreen", camera=rig, quality="flat"), None) as r:
        r.draw(SceneFrame(0.0, (me, ahead), None, NOON), follow="me")
        with_car = r.camera_images()
        r.draw(SceneFrame(0.0, (me,), None, NOON), follow="me")
        without = r.camera_images()
    save_shot("stereo_left_eye", with_car[0])
    near = ahead.x - ahead.length / 2  # [m] the car's near face
    for eye, side, tan_left in ((0, 1.0, -1.0), (1, -1.0, -0.5)):
        lit = changed(with_car[eye], without[eye])
        cols, rows = np.flatnonzero(lit.any(axis=0)), np.flatnonzero(lit.any(axis=1))
        assert cols.size, f"eye {eye}: the car is not in the picture"
        eye_y = side * IPD / 2  # [m] the eye's place left of the head
        # right of the eye: −(y − eye_y); the car's sides at y = ±width/2, seen at its near face
        left_edge = -(ahead.width / 2 - eye_y) / near
        right_edge = -(-ahead.width / 2 - eye_y) / near
        assert cols.min() == pytest.approx(column(left_edge, tan_left), abs=2.0)
        assert cols.max() + 1 == pytest.approx(column(right_edge, tan_left), abs=2.0)
        # rows from the top: (tan(up) − tan)/1.5 · px; the near face's bottom edge on the
        # ground, the roof's far edge highest
        bottom = (0.5 + EYE_Z / near) / 1.5 * EYE_PX
        top = (0.5 + (EYE_Z - ahead.height) / (ahead.x + ahead.length / 2)) / 1.5 * EYE_PX
        assert rows.max() + 1 == pytest.approx(bottom, abs=2.0)
        assert rows.min() == pytest.approx(top, abs=2.0)
    # A symmetric 90° lens would centre the car (column 150); the off-axis left eye puts it at
    # 200, the right eye at 100: the nasal sides are narrower.
    assert np.flatnonzero(changed(with_car[0], without[0]).any(axis=0)).mean() > 180
    assert np.flatnonzero(changed(with_car[1], without[1]).any(axis=0)).mean() < 120


def test_the_headsets_own_frusta_replace_the_rig_files() -> None:
    """`set_eye_frusta` (the view does it each frame with the headset's angles): the left eye
    given the right eye's frustum sees the car where that frustum puts it."""
    from carlaverse.render.renderer import Renderer

    rig = XrRig(eye_resolution=Resolution(width=EYE_PX, height=EYE_PX), left_eye=LEFT_EYE,
                right_eye=RIGHT_EYE, ipd_m=0.0, head=HeadPosition(z=EYE_Z))  # fmt: skip
    me = car("me", 0.0, 0.0, kind="pedestrian", ego=True)
    ahead = car("ahead", 20.0, 0.0)
    # flat: the camera maths is judged on the silhouette, and a shaded car also shadows the road
    with Renderer(RenderConfig(output="offscreen", camera=rig, quality="flat"), None) as r:
        mirrored = (RIGHT_EYE.fov(), LEFT_EYE.fov())
        r.rig.set_eye_frusta(mirrored)
        r.draw(SceneFrame(0.0, (me, ahead), None, NOON), follow="me")
        with_car = r.camera_images()
        r.draw(SceneFrame(0.0, (me,), None, NOON), follow="me")
        without = r.camera_images()
    near = ahead.x - ahead.length / 2
    for eye, tan_left in ((0, -0.5), (1, -1.0)):  # now the left eye spans −0.5..1
        cols = np.flatnonzero(changed(with_car[eye], without[eye]).any(axis=0))
        centre = (cols.min() + cols.max() + 1) / 2
        assert centre == pytest.approx(column(0.0, tan_left), abs=2.0)
        width = cols.max() + 1 - cols.min()
        assert width == pytest.approx(ahead.width / near / 1.5 * EYE_PX, abs=2.0)
