"""Per-eye fields of view: OpenXR's asymmetric frusta, the paper's symmetric render and crop.

OpenXR gives each eye four angles [rad] from the view direction: `left` and `down` are
negative, `right` and `up` positive; a headset's eye is wider outwards than towards the nose.
A renderer with an off-axis lens (Panda3D's film offset, `carlaverse.render.stereo`) draws that
frustum directly. A camera that accepts one symmetric FOV (CARLA's) renders the symmetric
field that holds the eye's (the paper's FOV_sym = 2·max(|θ_left|, |θ_right|)), and the eye's
window is then cut out of the picture: `symmetric_render` says how large to render and where
the window lies, with the eye's pixel density kept, so the crop is a plain sub-rectangle
(texture coordinates in the compositor: no resampling, no CPU work).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct

Angle = Annotated[float, msgspec.Meta(gt=-90.0, lt=90.0)]


@dataclass(frozen=True, slots=True)
class EyeFov:
    """OpenXR's `XrFovf` [rad]: left < right, down < up, each within ±90°."""

    left: float
    right: float
    up: float
    down: float

    def __post_init__(self) -> None:
        half = math.pi / 2
        if not (-half < self.left < self.right < half and -half < self.down < self.up < half):
            raise ValueError(f"not a frustum: {self}; need −90° < left < right < 90° and "
                             "−90° < down < up < 90°")  # fmt: skip

    @property
    def tangents(self) -> tuple[float, float, float, float]:
        """(tan left, tan right, tan down, tan up): the frustum on the plane one unit ahead."""
        return (math.tan(self.left), math.tan(self.right), math.tan(self.down),
                math.tan(self.up))  # fmt: skip


class EyeAngles(StrictStruct):
    """One eye's field of view in a config file [deg], as OpenXR reports it: left and down
    negative."""

    left_deg: Angle
    right_deg: Angle
    up_deg: Angle
    down_deg: Angle

    def fov(self) -> EyeFov:
        return EyeFov(*(math.radians(a) for a in (self.left_deg, self.right_deg, self.up_deg,
                                                   self.down_deg)))  # fmt: skip


def symmetric_fov(fov: EyeFov) -> float:
    """FOV_sym = 2·max(|θ_left|, |θ_right|) [rad]: the horizontal field that holds the eye's."""
    return 2.0 * max(abs(fov.left), abs(fov.right))


def symmetric_vertical_fov(fov: EyeFov) -> float:
    """The same for the vertical: 2·max(|θ_up|, |θ_down|) [rad]."""
    return 2.0 * max(abs(fov.up), abs(fov.down))


@dataclass(frozen=True, slots=True)
class CropWindow:
    """Where the eye's picture lies in the symmetric render [px]: columns x0..x1 (left to
    right), rows y0..y1 (top to bottom), and the same as texture coordinates 0..1 (u left to
    right, v bottom to top, OpenGL's)."""

    x0: float
    x1: float
    y0: float
    y1: float
    u0: float
    u1: float
    v0: float
    v1: float


@dataclass(frozen=True, slots=True)
class SymmetricRender:
    fov_h: float  # [rad] the symmetric camera's horizontal field (FOV_sym)
    fov_v: float  # [rad] its vertical field, from its aspect ratio
    width_px: int
    height_px: int
    crop: CropWindow


def symmetric_render(fov: EyeFov, eye_width_px: int, eye_height_px: int) -> SymmetricRender:
    """The symmetric render holding the eye's frustum at the eye's pixel density.

    On the image plane one unit ahead the eye spans tan(left)..tan(right) over `eye_width_px`
    columns, so a pixel is (tan r − tan l)/width wide; the symmetric render spans
    ±tan(FOV_sym/2) at that density (and ±tan of the vertical equivalent), rounded up to
    whole pixels. Pixels are square on that plane (as OpenXR's recommended image sizes are,
    near enough), so `eye_height_px` only checks the caller's aspect. CARLA derives the
    vertical field from the aspect ratio, so it is returned.
    """
    if eye_width_px <= 0 or eye_height_px <= 0:
        raise ValueError(f"eye image {eye_width_px}x{eye_height_px} px: sizes must be > 0")
    tl, tr, td, tu = fov.tangents
    density = eye_width_px / (tr - tl)  # [px per unit tangent]
    half_w = math.tan(symmetric_fov(fov) / 2)
    half_h = math.tan(symmetric_vertical_fov(fov) / 2)
    width = math.ceil(2 * half_w * density - 1e-9)
    height = math.ceil(2 * half_h * density - 1e-9)
    cx, cy = width / 2, height / 2
    x0, x1 = cx + tl * density, cx + tr * density
    y0, y1 = cy - tu * density, cy - td * density
    crop = CropWindow(x0, x1, y0, y1, x0 / width, x1 / width, 1 - y1 / height, 1 - y0 / height)
    fov_v = 2 * math.atan(math.tan(symmetric_fov(fov) / 2) * height / width)
    return SymmetricRender(symmetric_fov(fov), fov_v, width, height, crop)
