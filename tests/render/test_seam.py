"""A straight road edge crosses the seams of a three-display physical rig without a kink.

The check uses the displays' physical geometry, not the renderer's cameras: display j is a
flat panel of visible width b − 2k at distance d, turned by o_j. For each pixel column of
each panel we work out, from the known straight edge on the ground, the row at which a
viewer's eye sees that edge, and compare with the row where the picture changes from kerb to
ground. A rig whose field of view or yaw were wrong would show the edge shifted or bent at
the seams; the control below proves this test sees that.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import (
    HeadPosition,
    ManualCamera,
    ManualRig,
    PhysicalRig,
    RenderConfig,
    Resolution,
    physical_yaws,
)
from tests.render.support import car

pytestmark = pytest.mark.usefixtures("offscreen_gl")

W, H = 320, 180
B, K, D = 0.60, 0.02, 0.70  # [m] display width, bezel, eye distance
HEAD = HeadPosition(x=0.0, y=0.0, z=1.2)
EDGE_Y = -6.0  # [m] the kerb's near edge runs along y = −6 (parallel to the ego, to its right)
KERB_Z = 0.12  # [m] a sidewalk's surface
SIDEWALK = m.MapLane("walk_0", "sidewalk", 40.0, [(-50.0, EDGE_Y - 20.0), (400.0, EDGE_Y - 20.0)])
ROAD_MAP = m.MapReply(m.SCHEMA_VERSION, "seam", (-50.0, -60.0, 400.0, 60.0), [SIDEWALK])
WEATHER = m.Weather(0, 0.0, sun_altitude_deg=60.0)


def physical(displays: int = 3) -> PhysicalRig:
    return PhysicalRig(
        displays=displays,
        resolution=Resolution(width=W, height=H),
        display_width_m=B,
        bezel_m=K,
        distance_m=D,
        head=HEAD,
    )


def expected_row(display_yaw: float, column: int) -> float | None:
    """Row (0 = top) where the eye sees the edge through this column of the panel, or None."""
    visible = B - 2 * K
    u_right = (column + 0.5 - W / 2) * visible / W  # [m] on the panel, right of its centre
    c, s = math.cos(display_yaw), math.sin(display_yaw)
    left = s * D - c * u_right  # [m] the panel point's leftward offset in the head frame
    if left >= 0:
        return None  # this column looks left of straight ahead: never at the kerb on the right
    t = EDGE_Y / left  # the ray (fwd, left)·t meets y = EDGE_Y
    v_up = (KERB_Z - HEAD.z) / t  # [m] on the panel: the same t scales the panel point
    return H / 2 - v_up * W / visible


def kerb_bottom(img: np.ndarray) -> np.ndarray:
    """Per column, the row just below the lowest kerb pixel (NaN where there is none)."""
    r, g, b = (img[..., i].astype(int) for i in range(3))
    kerb = (abs(r - g) < 12) & (abs(g - b) < 16) & (r > 60)  # grey, not green ground or blue sky
    rows = np.full(img.shape[1], np.nan)
    for col in range(img.shape[1]):
        hits = np.flatnonzero(kerb[:, col])
        if hits.size:
            rows[col] = hits.max() + 1
    return rows


def edge_errors(config: RenderConfig, save_shot, name: str) -> list[float]:
    """|observed − expected| row per column, over all columns of all displays."""
    frame = SceneFrame(0.0, (car("me", 0.0, 0.0, ego=True),), None, WEATHER)
    with Renderer(config, ROAD_MAP) as r:
        r.draw(frame, follow="me")
        save_shot(name, r.images()[0])
        panels = r.camera_images()
    errors = []
    for yaw, img in zip(physical_yaws(3, B, D), panels, strict=True):
        observed = kerb_bottom(img)
        for col in range(W):
            want = expected_row(yaw, col)
            if want is not None and 2 < want < H - 2 and not np.isnan(observed[col]):
                errors.append(abs(observed[col] - want))
    return errors


def test_edge_is_continuous_across_the_seams(save_shot) -> None:
    errors = edge_errors(RenderConfig(output="offscreen", camera=physical()), save_shot, "seam")
    assert len(errors) > 200  # the edge runs through the centre and the right display
    assert max(errors) <= 1.5, f"edge off by up to {max(errors):.2f} px"


def test_control_a_rig_without_bezel_compensation_shows_a_shift(save_shot) -> None:
    """The same displays with the bezel ignored (FOV of the whole display) are caught."""
    step = math.degrees(physical_yaws(3, B, D)[0])
    naive = ManualRig(
        displays=3,
        windows="span",
        resolution=Resolution(width=W, height=H),
        head=HEAD,
        cameras=[ManualCamera(display=j, yaw_deg=step * (1 - j), fov_deg=step) for j in range(3)],
    )
    errors = edge_errors(RenderConfig(output="offscreen", camera=naive), save_shot, "seam_naive")
    assert max(errors) > 3.0
