"""Camera rigs: which cameras look where, and onto which part of which display.

Three modes, as in the paper's visualization module:

- `simple`: one continuous screen; the horizontal field of view is split over `views`
  cameras rendered side by side (one camera by default).
- `physical`: M identical displays arranged around the head. Each camera's horizontal field
  of view is  f = 2·atan((b/2 − k)/d)  and its yaw is  o_i = i·2·acos(d/√((b/2)² + d²)),
  i = −n..n for odd M and ±n/2 (n = 1, 3, …, M−1) for even M, where b is a display's width,
  k its side frame (bezel) and d the distance from the head. (The paper writes n ≤ M/2 for
  even M; read literally that puts four displays at ±1/2 and ±1 steps, overlapping. The
  displays' centres are half-odd steps from the middle: ±1/2, ±3/2, … — identical for M = 2.)
  The yaw step is the angle a whole display (frame included) subtends, the field of view only
  its visible part, so the scene hidden behind two frames is exactly what a window frame
  would hide: no seam shift.
- `manual`: every camera given by yaw, pitch, field of view and viewport (CAVEs, odd mounts).

Angles in this module's outputs are radians; configs use degrees. Yaw is positive to the
left (counter-clockwise seen from above, like the world's yaw); displays are numbered left
to right. Nothing here imports Panda3D: the maths is testable on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.fov import EyeAngles, EyeFov
from carlaverse.render.own_config import OwnView

Degrees = Annotated[float, msgspec.Meta(gt=0.0, lt=180.0)]
Pixels = Annotated[int, msgspec.Meta(ge=8, le=16384)]
Fraction = Annotated[float, msgspec.Meta(ge=0.0, le=1.0)]
Metres = Annotated[float, msgspec.Meta(gt=0.0)]


class Resolution(StrictStruct):
    width: Pixels = 1920
    height: Pixels = 1080


class HeadPosition(StrictStruct):
    """The eye point in the actor frame (x forward, y left, z up from the ground) [m]."""

    x: float = 0.0
    y: float = 0.0
    z: float = 1.2


class SimpleRig(StrictStruct, tag="simple", tag_field="mode"):
    resolution: Resolution = Resolution()
    fov_deg: Degrees = 90.0  # horizontal, over the whole screen
    views: Annotated[int, msgspec.Meta(ge=1, le=16)] = 1
    head: HeadPosition = HeadPosition()
    # the screen's middle above the eye's horizontal (negative: below, as a cyclist's gaze)
    pitch_deg: Annotated[float, msgspec.Meta(ge=-60.0, le=60.0)] = 0.0


class PhysicalRig(StrictStruct, tag="physical", tag_field="mode"):
    displays: Annotated[int, msgspec.Meta(ge=1, le=16)] = 3
    resolution: Resolution = Resolution()  # of one display
    display_width_m: Metres = 0.60  # b: the whole display, frames included
    bezel_m: Annotated[float, msgspec.Meta(ge=0.0)] = 0.0  # k: one side frame
    distance_m: Metres = 0.70  # d: head to display surface
    windows: Literal["span", "per_display"] = "span"
    head: HeadPosition = HeadPosition()


class ManualCamera(StrictStruct):
    yaw_deg: float = 0.0  # left positive
    pitch_deg: float = 0.0  # up positive
    roll_deg: float = 0.0
    fov_deg: Degrees = 60.0  # horizontal
    display: Annotated[int, msgspec.Meta(ge=0)] = 0
    # [left, right, bottom, top] fractions of the display (Panda3D's order)
    viewport: tuple[Fraction, Fraction, Fraction, Fraction] = (0.0, 1.0, 0.0, 1.0)


class ManualRig(StrictStruct, tag="manual", tag_field="mode"):
    cameras: list[ManualCamera]
    resolution: Resolution = Resolution()  # of one display
    displays: Annotated[int, msgspec.Meta(ge=1, le=16)] = 1
    windows: Literal["span", "per_display"] = "per_display"
    head: HeadPosition = HeadPosition()


XrEye = EyeAngles  # one eye's field of view [deg], as OpenXR reports it


class XrRig(StrictStruct, tag="xr", tag_field="mode"):
    """A headset: two eyes side by side, each drawn with its own asymmetric frustum (an
    off-axis lens, `render/stereo.py`); the defaults are wider outwards than towards the nose,
    as headsets are. A walk node whose headset reports its eyes (OpenXR, or the sim's
    `eyes:`) overrides them with the runtime's angles every frame."""

    eye_resolution: Resolution = Resolution(width=1024, height=1024)
    left_eye: XrEye = XrEye(left_deg=-50.0, right_deg=40.0, up_deg=45.0, down_deg=-50.0)
    right_eye: XrEye = XrEye(left_deg=-40.0, right_deg=50.0, up_deg=45.0, down_deg=-50.0)
    ipd_m: Annotated[float, msgspec.Meta(ge=0.0, le=0.1)] = 0.063  # [m] between the pupils
    head: HeadPosition = HeadPosition(z=1.65)


Rig = SimpleRig | PhysicalRig | ManualRig | XrRig


class RenderConfig(StrictStruct):
    """The `render:` section of a node config, or a rig file of its own."""

    output: Literal["offscreen", "window"] = "window"
    camera: Rig = SimpleRig()
    max_fps: Annotated[float, msgspec.Meta(gt=0.0)] = 60.0
    draw_distance_m: Metres = 400.0
    # auto | full | cpu | flat: what the renderer draws and may cost (render/quality.py)
    quality: Literal["auto", "full", "cpu", "flat"] = "auto"
    own: OwnView = OwnView()  # cockpit, handlebar, mirrors, HUD, a two-wheeler's lean


@dataclass(frozen=True, slots=True)
class CameraView:
    """One camera of a rig, resolved: where it looks and where its image goes."""

    name: str
    output: int  # index of the window or offscreen buffer
    viewport: tuple[float, float, float, float]  # left, right, bottom, top of that output
    yaw: float  # [rad] left positive, relative to the head
    pitch: float  # [rad] up positive
    roll: float  # [rad]
    fov_h: float  # [rad]
    fov_v: float  # [rad]
    width_px: int  # pixel size of the viewport
    height_px: int
    frustum: EyeFov | None = None  # an asymmetric eye frustum (drawn off-axis), else fov_h/v
    offset_left_m: float = 0.0  # [m] the camera's place left of the head (an eye's half IPD)


@dataclass(frozen=True, slots=True)
class RigLayout:
    cameras: tuple[CameraView, ...]
    outputs: tuple[tuple[int, int], ...]  # (width, height) [px] per window or buffer
    head: HeadPosition


# ----------------------------------------------------------------- the paper's formulas


def physical_fov(display_width_m: float, bezel_m: float, distance_m: float) -> float:
    """f = 2·atan((b/2 − k)/d) [rad]: what the visible part of one display subtends."""
    visible_half = display_width_m / 2 - bezel_m
    if visible_half <= 0:
        raise ValueError(
            f"bezel_m = {bezel_m} leaves no picture on a {display_width_m} m display; "
            "the bezel is one side frame and must be under half the display width"
        )
    return 2 * math.atan(visible_half / distance_m)


def display_factors(displays: int) -> list[float]:
    """The factors i of the paper, left to right: −n..n (odd M) or ±n/2 (even M)."""
    return [(displays - 1) / 2 - j for j in range(displays)]


def physical_yaws(displays: int, display_width_m: float, distance_m: float) -> list[float]:
    """o_i = i·2·acos(d/√((b/2)² + d²)) [rad], left to right (left positive)."""
    half_b = display_width_m / 2
    step = 2 * math.acos(distance_m / math.sqrt(half_b**2 + distance_m**2))
    return [i * step for i in display_factors(displays)]


def vertical_fov(fov_h: float, width_px: int, height_px: int) -> float:
    """Vertical field of view for square pixels [rad]."""
    return 2 * math.atan(math.tan(fov_h / 2) * height_px / width_px)


# ----------------------------------------------------------------- layouts


def layout(rig: Rig) -> RigLayout:
    """Resolve a rig config into cameras, viewports and output sizes."""
    if isinstance(rig, SimpleRig):
        return _simple(rig)
    if isinstance(rig, PhysicalRig):
        return _physical(rig)
    if isinstance(rig, XrRig):
        return _xr(rig)
    return _manual(rig)


def _simple(rig: SimpleRig) -> RigLayout:
    w, h, n = rig.resolution.width, rig.resolution.height, rig.views
    fov_total = math.radians(rig.fov_deg)
    slice_fov = fov_total / n  # equal angular slices across the one screen
    pitch = math.radians(rig.pitch_deg)
    cams = []
    for j in range(n):
        yaw = fov_total / 2 - slice_fov * (j + 0.5)
        width_px = round(w * (j + 1) / n) - round(w * j / n)
        viewport = (j / n, (j + 1) / n, 0.0, 1.0)
        fov_v = vertical_fov(slice_fov, width_px, h)
        cams.append(
            CameraView(f"view{j}", 0, viewport, yaw, pitch, 0.0, slice_fov, fov_v, width_px, h)
        )
    return RigLayout(tuple(cams), ((w, h),), rig.head)


def _physical(rig: PhysicalRig) -> RigLayout:
    w, h, m = rig.resolution.width, rig.resolution.height, rig.displays
    fov_h = physical_fov(rig.display_width_m, rig.bezel_m, rig.distance_m)
    fov_v = vertical_fov(fov_h, w, h)
    yaws = physical_yaws(m, rig.display_width_m, rig.distance_m)
    cams = []
    for j, yaw in enumerate(yaws):
        output, viewport = _display_slot(j, m, rig.windows)
        cams.append(CameraView(f"display{j}", output, viewport, yaw, 0.0, 0.0, fov_h, fov_v, w, h))
    return RigLayout(tuple(cams), _output_sizes(m, w, h, rig.windows), rig.head)


def _manual(rig: ManualRig) -> RigLayout:
    w, h, m = rig.resolution.width, rig.resolution.height, rig.displays
    cams = []
    for j, cam in enumerate(rig.cameras):
        if cam.display >= m:
            raise ValueError(
                f"camera.cameras[{j}].display = {cam.display} but the rig has {m} displays; "
                f"use 0..{m - 1} or raise camera.displays"
            )
        output, (d_left, d_right, _, _) = _display_slot(cam.display, m, rig.windows)
        left, right, bottom, top = cam.viewport
        if right <= left or top <= bottom:
            raise ValueError(f"camera.cameras[{j}].viewport {cam.viewport} is empty")
        span = d_right - d_left
        viewport = (d_left + left * span, d_left + right * span, bottom, top)
        width_px, height_px = round(w * (right - left)), round(h * (top - bottom))
        fov_h = math.radians(cam.fov_deg)
        cams.append(
            CameraView(
                f"camera{j}", output, viewport, math.radians(cam.yaw_deg),
                math.radians(cam.pitch_deg), math.radians(cam.roll_deg), fov_h,
                vertical_fov(fov_h, width_px, height_px), width_px, height_px,
            )
        )  # fmt: skip
    return RigLayout(tuple(cams), _output_sizes(m, w, h, rig.windows), rig.head)


def _xr(rig: XrRig) -> RigLayout:
    w, h = rig.eye_resolution.width, rig.eye_resolution.height
    cams = []
    for j, (name, eye, side) in enumerate((("left_eye", rig.left_eye, 1.0),
                                           ("right_eye", rig.right_eye, -1.0))):  # fmt: skip
        fov = eye.fov()
        viewport = (j / 2, (j + 1) / 2, 0.0, 1.0)
        cams.append(CameraView(name, 0, viewport, 0.0, 0.0, 0.0, fov.right - fov.left,
                               fov.up - fov.down, w, h, fov, side * rig.ipd_m / 2))  # fmt: skip
    return RigLayout(tuple(cams), ((2 * w, h),), rig.head)


def _display_slot(
    display: int, displays: int, windows: str
) -> tuple[int, tuple[float, float, float, float]]:
    """Which output a display is, and which part of it."""
    if windows == "per_display":
        return display, (0.0, 1.0, 0.0, 1.0)
    return 0, (display / displays, (display + 1) / displays, 0.0, 1.0)


def _output_sizes(displays: int, w: int, h: int, windows: str) -> tuple[tuple[int, int], ...]:
    if windows == "per_display":
        return tuple((w, h) for _ in range(displays))
    return ((w * displays, h),)


def project_column(camera: CameraView, forward_m: float, left_m: float) -> float:
    """Pixel column (0 = left edge of the viewport) where a head-frame point appears.

    `forward_m`/`left_m` are in the head's horizontal frame; the camera's yaw is undone first.
    Used by tests and by anything placing 2D overlays.
    """
    c, s = math.cos(camera.yaw), math.sin(camera.yaw)
    fwd = c * forward_m + s * left_m
    left = -s * forward_m + c * left_m
    if fwd <= 0:
        raise ValueError("the point is behind the camera")
    ndc_x = (-left / fwd) / math.tan(camera.fov_h / 2)
    return (ndc_x + 1) / 2 * camera.width_px
