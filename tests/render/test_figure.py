"""Walkers articulated from their skeleton: a raised arm shows where the maths puts it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.figure import LIMBS, SHOULDER_Z
from carlaverse.render.frame import ActorDraw, SceneFrame, joint_angles
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import (
    HeadPosition,
    RenderConfig,
    Resolution,
    SimpleRig,
    layout,
    project_column,
)
from tests.render.support import car, changed, project_row

HEAD = HeadPosition(x=0.0, y=0.0, z=1.2)
RIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=320, height=180), fov_deg=90, head=HEAD),
)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)
DISTANCE_M = 4.0  # [m] the walker stands this far ahead, facing the camera


def _skeleton(angles: dict[str, tuple[float, float, float]]) -> m.Skeleton:
    raw = np.array([angles[j] for j in angles], dtype="<f4").tobytes()
    return m.Skeleton(1, 0.0, list(angles), raw)


def _walker(angles: dict[str, tuple[float, float, float]]) -> ActorDraw:
    return ActorDraw("walker", "pedestrian", DISTANCE_M, 0.0, 0.0, math.pi, 0.5, 0.6, 1.75,
                     skeleton=angles)  # fmt: skip


def test_a_raised_arm_shows_above_the_head_on_the_walkers_left(save_shot) -> None:
    me = car("me", 0.0, 0.0, ego=True)
    rest = {"left_shoulder": (0.0, 0.0, 0.0)}
    raised = joint_angles(_skeleton({"left_shoulder": (math.pi, 0.0, 0.0)}))
    with Renderer(RIG, None) as r:
        shots = []
        for angles in (rest, raised):
            r.draw(SceneFrame(0.0, (me, _walker(angles)), None, NOON), follow="me")
            shots.append(r.images()[0])
    save_shot("figure_rest", shots[0])
    save_shot("figure_raised", shots[1])
    cam = layout(RIG.camera).cameras[0]
    # The walker faces -x, so its left is world -y: right of centre in the picture.
    limb = next(limb for limb in LIMBS if limb.joint == "left_shoulder")
    shoulder_left_m = -abs(limb.at[0])
    arm_top_m = SHOULDER_Z + limb.upper_m + limb.lower_m  # [m] above the ground, overhead
    head_top_row = project_row(cam, DISTANCE_M, 0.0, 1.75 - HEAD.z)
    above_head = changed(shots[1], shots[0])[: math.floor(head_top_row) - 1]
    rows, cols = np.nonzero(above_head)
    assert rows.size >= 6, "the raised arm does not reach above the head"
    expected_col = project_column(cam, DISTANCE_M, shoulder_left_m)
    assert cols.mean() == pytest.approx(expected_col, abs=2.0)
    assert expected_col > cam.width_px / 2  # on the right of the picture, as predicted
    assert rows.min() == pytest.approx(project_row(cam, DISTANCE_M, 0.0, arm_top_m - HEAD.z),
                                       abs=2.5)  # fmt: skip
    # where the arm hung at rest, beside the hip, it is gone
    hip_row = round(project_row(cam, DISTANCE_M, 0.0, 1.0 - HEAD.z))
    assert changed(shots[1], shots[0])[hip_row, round(expected_col)]
