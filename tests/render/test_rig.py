"""Camera rigs: the paper's formulas against values worked by hand, layouts, strict configs."""

from __future__ import annotations

import math

import msgspec
import pytest

from carlaverse.config import ConfigError, convert, load_config
from carlaverse.render.rig import (
    ManualCamera,
    ManualRig,
    PhysicalRig,
    RenderConfig,
    Resolution,
    SimpleRig,
    display_factors,
    layout,
    physical_fov,
    physical_yaws,
    project_column,
    vertical_fov,
)

# b = 0.60 m, k = 0.02 m, d = 0.70 m, by hand:
#   f = 2·atan((0.30 − 0.02)/0.70) = 2·atan(0.4) = 2 × 21.80141° = 43.60282°
#   step = 2·acos(0.70/√(0.30² + 0.70²)) = 2·acos(0.70/0.761577) = 2 × 23.19859° = 46.39718°
F_DEG, STEP_DEG = 43.60282, 46.39718


def test_fov_golden() -> None:
    assert math.degrees(physical_fov(0.60, 0.02, 0.70)) == pytest.approx(F_DEG, abs=1e-4)
    # no bezel: the field of view is the whole display's angle, the yaw step
    assert physical_fov(0.6, 0.0, 0.7) == pytest.approx(math.radians(STEP_DEG), abs=1e-7)


def test_yaw_offsets_golden() -> None:
    three = [math.degrees(o) for o in physical_yaws(3, 0.60, 0.70)]
    assert three == pytest.approx([STEP_DEG, 0.0, -STEP_DEG], abs=1e-4)
    two = [math.degrees(o) for o in physical_yaws(2, 0.60, 0.70)]
    assert two == pytest.approx([STEP_DEG / 2, -STEP_DEG / 2], abs=1e-4)
    five = [math.degrees(o) for o in physical_yaws(5, 0.60, 0.70)]
    assert five == pytest.approx([2 * STEP_DEG, STEP_DEG, 0, -STEP_DEG, -2 * STEP_DEG], abs=1e-4)


def test_factors_follow_the_paper() -> None:
    assert display_factors(1) == [0.0]
    assert display_factors(3) == [1.0, 0.0, -1.0]  # the paper's example: i = {-1, 0, 1}
    assert display_factors(4) == [1.5, 0.5, -0.5, -1.5]  # adjacent displays one step apart


def test_bezel_too_wide_is_named() -> None:
    with pytest.raises(ValueError, match=r"bezel_m = 0\.3"):
        physical_fov(0.6, 0.3, 0.7)


def test_physical_layout_span_and_per_display() -> None:
    rig = PhysicalRig(
        displays=3,
        resolution=Resolution(width=320, height=180),
        display_width_m=0.6,
        bezel_m=0.02,
        distance_m=0.7,
    )
    span = layout(rig)
    assert span.outputs == ((960, 180),)
    assert [c.viewport[:2] for c in span.cameras] == [(0, 1 / 3), (1 / 3, 2 / 3), (2 / 3, 1)]
    # 320×180 at f = 43.60282°: v = 2·atan(0.4 × 180/320) = 2·atan(0.225) = 25.36077°
    assert math.degrees(span.cameras[0].fov_v) == pytest.approx(25.36077, abs=1e-4)
    per = layout(msgspec.structs.replace(rig, windows="per_display"))
    assert per.outputs == ((320, 180),) * 3 and [c.output for c in per.cameras] == [0, 1, 2]


def test_simple_splits_the_screen() -> None:
    lay = layout(SimpleRig(fov_deg=120, views=3, resolution=Resolution(width=300, height=100)))
    assert [math.degrees(c.yaw) for c in lay.cameras] == pytest.approx([40, 0, -40])
    assert all(math.degrees(c.fov_h) == pytest.approx(40) for c in lay.cameras)
    assert sum(c.width_px for c in lay.cameras) == 300


def test_manual_viewports_land_in_their_display() -> None:
    rig = ManualRig(
        displays=2,
        windows="span",
        resolution=Resolution(width=200, height=100),
        cameras=[ManualCamera(display=1, viewport=(0.5, 1.0, 0.0, 0.5), yaw_deg=-90)],
    )
    cam = layout(rig).cameras[0]
    assert cam.viewport == (0.75, 1.0, 0.0, 0.5)
    assert (cam.width_px, cam.height_px) == (100, 50)
    with pytest.raises(ValueError, match=r"cameras\[0\].display = 2"):
        layout(msgspec.structs.replace(rig, cameras=[ManualCamera(display=2)]))


def test_vertical_fov_and_projection() -> None:
    assert vertical_fov(math.radians(90), 100, 100) == pytest.approx(math.radians(90))
    cam = layout(SimpleRig(fov_deg=90, resolution=Resolution(width=200, height=100))).cameras[0]
    assert project_column(cam, 10.0, 0.0) == pytest.approx(100.0)
    assert project_column(cam, 10.0, 10.0) == pytest.approx(0.0)  # 45° left: the left edge
    assert project_column(cam, 10.0, -5.0) == pytest.approx(150.0)


def test_config_from_yaml_is_strict(tmp_path) -> None:
    good = tmp_path / "rig.yaml"
    good.write_text(
        "output: offscreen\ncamera:\n  mode: physical\n  displays: 3\n  bezel_m: 0.02\n"
    )
    cfg = load_config(good, RenderConfig)
    assert isinstance(cfg.camera, PhysicalRig) and cfg.camera.bezel_m == 0.02
    with pytest.raises(ConfigError, match=r"unknown field `bezle_m` - at `\$\.camera`"):
        convert({"camera": {"mode": "physical", "bezle_m": 0.02}}, RenderConfig, "rig.yaml")
    with pytest.raises(ConfigError, match=r"\$\.camera\.distance_m"):
        convert({"camera": {"mode": "physical", "distance_m": -1}}, RenderConfig, "rig.yaml")
    with pytest.raises(ConfigError, match="mode"):
        convert({"camera": {"mode": "fisheye"}}, RenderConfig, "rig.yaml")


@pytest.mark.parametrize(
    "name", ["rig-desktop", "rig-three-displays", "rig-cave", "rig-bike-desktop"]
)
def test_shipped_rigs_load(name: str) -> None:
    cfg = load_config(f"rigs/{name}", RenderConfig)
    assert layout(cfg.camera).cameras
