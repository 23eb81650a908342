"""Off-axis (asymmetric) lenses for headset eyes: Panda3D film size and film offset.

A Panda3D perspective lens images the film, a rectangle at the focal length ahead of the
camera; with the focal length 1 the film is the image plane one unit ahead, where an eye's
frustum spans tan(left)..tan(right) across and tan(down)..tan(up) up. So the film is that
rectangle's size and its centre, offset from the optical axis, is the film offset: the lens
draws exactly the OpenXR frustum, no symmetric render and no crop (`fov.py` has those
for renderers that take one symmetric FOV, like CARLA's cameras).
"""

from __future__ import annotations

from panda3d.core import PerspectiveLens

from carlaverse.fov import EyeFov


def off_axis_lens(fov: EyeFov, near_m: float, far_m: float) -> PerspectiveLens:
    """A lens whose frustum is the eye's `fov` [rad], clipped at `near_m`..`far_m`."""
    lens = PerspectiveLens()
    lens.set_near_far(near_m, far_m)
    aim_off_axis(lens, fov)
    return lens


def aim_off_axis(lens: PerspectiveLens, fov: EyeFov) -> None:
    """Give `lens` the eye's frustum: film one unit ahead, sized and offset to it."""
    tl, tr, td, tu = fov.tangents
    lens.set_focal_length(1.0)
    lens.set_film_size(tr - tl, tu - td)
    lens.set_film_offset((tr + tl) / 2, (tu + td) / 2)
