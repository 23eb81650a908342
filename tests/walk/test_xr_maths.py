"""The paper's VR maths with golden values worked by hand: the symmetric FOV and its crop, and
the head pose from OpenXR (x right, y up, −z forward) into the world and into Unreal."""

from __future__ import annotations

import math

import pytest

from carlaverse.fov import EyeFov, symmetric_fov, symmetric_render
from carlaverse.hal.xr.frames import (
    StageAnchor,
    openxr_to_world,
    unreal_rotation,
    unreal_rotation_yzx,
    yzx_euler,
)
from carlaverse.render.carla_bridge import to_unreal

DEG = math.pi / 180
IDENTITY = (1.0, 0.0, 0.0, 0.0)


def about(axis: str, angle: float) -> tuple[float, float, float, float]:
    """A rotation by `angle` [rad] about OpenXR's +x, +y or +z, as (w, x, y, z)."""
    c, s = math.cos(angle / 2), math.sin(angle / 2)
    return {"x": (c, s, 0.0, 0.0), "y": (c, 0.0, s, 0.0), "z": (c, 0.0, 0.0, s)}[axis]


def hamilton(p: tuple, q: tuple) -> tuple[float, float, float, float]:
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


# ------------------------------------------------------------------ FOV_sym and the crop


def test_symmetric_fov_is_twice_the_wider_side() -> None:
    # A left eye 52° outwards (left) and 42° towards the nose: FOV_sym = 2·52° = 104°.
    left_eye = EyeFov(-52 * DEG, 42 * DEG, 46 * DEG, -50 * DEG)
    assert symmetric_fov(left_eye) == pytest.approx(104 * DEG)
    right_eye = EyeFov(-42 * DEG, 52 * DEG, 46 * DEG, -50 * DEG)
    assert symmetric_fov(right_eye) == pytest.approx(104 * DEG)


def test_crop_of_a_left_eye_keeps_its_pixels_and_cuts_the_nasal_side() -> None:
    # tan(left) = −1, tan(right) = 0.5, tan(up) = 0.5, tan(down) = −1; 600 px wide.
    # Density 600 / 1.5 = 400 px per unit tangent. FOV_sym = 90° spans ±1 → 800 px;
    # vertically ±tan 45° = ±1 → 800 px. Centre (400, 400): the eye's columns are
    # 400 − 400 = 0 .. 400 + 200 = 600, its rows 400 − 200 = 200 .. 400 + 400 = 800.
    fov = EyeFov(-math.atan(1.0), math.atan(0.5), math.atan(0.5), -math.atan(1.0))
    render = symmetric_render(fov, 600, 600)
    assert render.fov_h == pytest.approx(math.pi / 2)
    assert render.fov_v == pytest.approx(math.pi / 2)
    assert (render.width_px, render.height_px) == (800, 800)
    c = render.crop
    assert (c.x0, c.x1, c.y0, c.y1) == pytest.approx((0, 600, 200, 800))
    # texture coordinates: u = x / 800, v from the bottom = 1 − y / 800
    assert (c.u0, c.u1, c.v0, c.v1) == pytest.approx((0.0, 0.75, 0.0, 0.75))


def test_crop_of_the_mirrored_right_eye_cuts_its_left_part() -> None:
    fov = EyeFov(-math.atan(0.5), math.atan(1.0), math.atan(0.5), -math.atan(1.0))
    c = symmetric_render(fov, 600, 600).crop
    assert (c.x0, c.x1) == pytest.approx((200, 800))  # the nasal 200 px on the left go


def test_a_frustum_that_is_not_one_is_refused() -> None:
    with pytest.raises(ValueError, match="not a frustum"):
        EyeFov(0.5, -0.5, 0.4, -0.4)


# ------------------------------------------------------------------ OpenXR -> world


def test_stage_position_lands_in_the_world() -> None:
    # The head 1 m forward (−z) and 0.5 m right (+x) of the stage origin, eyes at 1.7 m.
    # Stage facing north (yaw 90°): forward is +y, right is +x → (10 + 0.5, 20 + 1, 1.7).
    head = openxr_to_world((0.5, 1.7, -1.0), IDENTITY, StageAnchor(10.0, 20.0, math.pi / 2))
    assert (head.x, head.y, head.z) == pytest.approx((10.5, 21.0, 1.7))
    assert (head.yaw, head.pitch, head.roll) == pytest.approx((math.pi / 2, 0.0, 0.0))
    # Stage facing east: forward is +x, right is −y → (11, 19.5).
    head = openxr_to_world((0.5, 1.7, -1.0), IDENTITY, StageAnchor(10.0, 20.0, 0.0))
    assert (head.x, head.y) == pytest.approx((11.0, 19.5))


def test_head_turned_left_nodding_and_tilting() -> None:
    east = StageAnchor(0.0, 0.0, 0.0)
    # +30° about +y turns the face left: world yaw +30° (counter-clockwise).
    assert openxr_to_world((0, 0, 0), about("y", 30 * DEG), east).yaw == pytest.approx(30 * DEG)
    # +20° about +x lifts the face: nose up, so ISO pitch (nose down positive) is −20°.
    assert openxr_to_world((0, 0, 0), about("x", 20 * DEG), east).pitch == pytest.approx(-20 * DEG)
    # +15° about +z (the back axis) raises the right ear: the left side goes down, ISO roll
    # (right side down positive) is −15°.
    assert openxr_to_world((0, 0, 0), about("z", 15 * DEG), east).roll == pytest.approx(-15 * DEG)


def test_turned_left_then_looking_up() -> None:
    # yaw 90° left, then 30° up about the head's own +x: facing north, nose up 30°.
    q = hamilton(about("y", 90 * DEG), about("x", 30 * DEG))
    head = openxr_to_world((0, 0, 0), q, StageAnchor(0.0, 0.0, 0.0))
    assert (head.yaw, head.pitch, head.roll) == pytest.approx((90 * DEG, -30 * DEG, 0.0), abs=1e-12)


# ------------------------------------------------------------------ OpenXR -> Unreal


def test_yzx_euler_recovers_the_three_angles() -> None:
    a, b, c = 40 * DEG, -25 * DEG, 10 * DEG
    q = hamilton(hamilton(about("y", a), about("z", b)), about("x", c))  # Ry·Rz·Rx, intrinsic
    assert yzx_euler(q) == pytest.approx((a, b, c))


@pytest.mark.parametrize("convert", [unreal_rotation_yzx, unreal_rotation])
@pytest.mark.parametrize(
    ("q", "pitch", "yaw", "roll"),
    [
        (IDENTITY, 0.0, 0.0, 0.0),
        (about("y", 30 * DEG), 0.0, -30.0, 0.0),  # face left: Unreal yaw is clockwise
        (about("x", 20 * DEG), 20.0, 0.0, 0.0),  # face up: Unreal pitch up positive
        (about("z", 15 * DEG), 0.0, 0.0, -15.0),  # left ear down: Unreal roll is right-down
        # turned 30° left and nodding 10° up (about the head's own +x)
        (hamilton(about("y", 30 * DEG), about("x", 10 * DEG)), 10.0, -30.0, 0.0),
        # turned 40° left and tilted 5° onto the left ear
        (hamilton(about("y", 40 * DEG), about("z", 5 * DEG)), 0.0, -40.0, -5.0),
    ],
)
def test_a_carla_camera_looks_where_the_head_looks(convert, q, pitch, yaw, roll) -> None:
    """Golden: the paper's YZX reading and the exact one agree while pitch or roll is zero."""
    rot = convert(q)
    assert (rot.pitch, rot.yaw, rot.roll) == pytest.approx((pitch, yaw, roll), abs=1e-9)


def test_unreal_rotation_adds_the_stage_heading() -> None:
    # The stage faces Unreal yaw 90° (south in the road network: CARLA's +y is our −y); the
    # head turned 30° left of it faces Unreal yaw 60°; turned and nodding 10° up.
    q = hamilton(about("y", 30 * DEG), about("x", 10 * DEG))
    for convert in (unreal_rotation_yzx, unreal_rotation):
        rot = convert(q, stage_yaw_deg=90.0)
        assert (rot.pitch, rot.yaw, rot.roll) == pytest.approx((10.0, 60.0, 0.0), abs=1e-9)


def test_nodding_while_tilted_needs_carlas_own_euler_order() -> None:
    """carla.Rotation turns by yaw, then pitch, then roll; a head 30° up and 30° tilted, built
    in that order, reads back exactly — and through the world frame and the CARLA bridge the
    same — while the YZX angles, applied in that order, would turn the camera 16° aside."""
    q = hamilton(about("x", 30 * DEG), about("z", 30 * DEG))  # pitch up, then tilt left
    exact = unreal_rotation(q)
    assert (exact.pitch, exact.yaw, exact.roll) == pytest.approx((30.0, 0.0, -30.0), abs=1e-9)
    head = openxr_to_world((0.0, 0.0, 0.0), q, StageAnchor())
    bridge = to_unreal(0.0, 0.0, 0.0, head.yaw, head.pitch, head.roll)
    assert (bridge.pitch, bridge.yaw, bridge.roll) == pytest.approx((30.0, 0.0, -30.0), abs=1e-9)
    paper = unreal_rotation_yzx(q)
    assert abs(paper.yaw) > 10.0  # 16.1°: the YZX angles are right for another order only
    a, b, c = yzx_euler(q)
    back = hamilton(hamilton(about("y", a), about("z", b)), about("x", c))
    assert back == pytest.approx(q, abs=1e-12)  # they do describe the same rotation in YZX
