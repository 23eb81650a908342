"""XR headsets: where the participant's head is, and what their controllers say.

Backends: `sim` (a seated or standing participant, scripted thumbstick; headless, seeded),
`mouse` (desktop mode: mouse look through pygame, no headset), `openxr` (a real headset through
pyopenxr: `pip install 'carlaverse[xr]'` and an OpenXR runtime). Third parties add more under
the entry-point group `carlaverse.hal.xr`.

Frame: x right, y up, z backwards (OpenXR's stage space), metres; orientation a unit
quaternion (w, x, y, z). `carlaverse.hal.xr.frames` turns it into the world and Unreal frames.
"""

from __future__ import annotations

import msgspec

from carlaverse.fov import EyeFov
from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.registry import BackendSpec, Registry
from carlaverse.hal.xr.eye_images import EyeFrame

BACKENDS = {
    "sim": BackendSpec("carlaverse.hal.xr.sim", "SimHeadset"),
    "mouse": BackendSpec("carlaverse.hal.xr.mouse", "MouseLook", "input"),
    "openxr": BackendSpec("carlaverse.hal.xr.openxr_headset", "OpenXrHeadset", "xr"),
}


class XrConfig(DeviceConfig):
    """`xr:` block of a node config."""


class HeadPose(msgspec.Struct, frozen=True):
    t: float  # [s] device clock
    position: tuple[float, float, float]  # [m]
    orientation: tuple[float, float, float, float]  # unit quaternion (w, x, y, z)
    tracked: bool = True  # False when tracking is lost; the pose is then the last good one


class XrActions(msgspec.Struct, frozen=True):
    """The locomotion actions bound on the controllers (OpenXR action set `walk`)."""

    move: tuple[float, float] = (0.0, 0.0)  # thumbstick: x right, y forward, each -1..1
    run: bool = False
    interact: bool = False
    hand_yaw: float | None = None  # [rad] the moving hand's yaw in stage space, when tracked


class XrHeadset(Device):
    """Base class: `pose` samples the head now, `actions` the controllers."""

    def pose(self) -> HeadPose:
        now = self.clock()
        position, orientation, tracked = self._pose(now)
        return HeadPose(now, position, orientation, tracked)

    def actions(self) -> XrActions:
        """The controllers now; a stick outside the unit circle is scaled back onto it."""
        raw = self._actions(self.clock())
        x, y = raw.move
        norm = (x * x + y * y) ** 0.5
        if norm > 1.0:
            raw = msgspec.structs.replace(raw, move=(x / norm, y / norm))
        return raw

    def eye_fovs(self) -> tuple[EyeFov, EyeFov] | None:
        """The (left, right) eyes' fields of view, when the headset reports them."""
        return None

    def display_size(self) -> tuple[int, int] | None:
        """(width, height) [px] of each eye's image when the headset shows rendered images
        (`present`); None for one that shows nothing (desktop mouse look)."""
        return None

    def present(self, eyes: EyeFrame) -> None:
        """Show this frame of both eyes from the next headset frame on."""
        raise NotImplementedError(f"{type(self).__name__} shows no images (display_size None)")

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        raise NotImplementedError

    def _actions(self, now: float) -> XrActions:
        """Backend hook; a headset without controllers reports none."""
        return XrActions()


def registry() -> Registry[XrHeadset]:
    return Registry("xr", XrHeadset, BACKENDS)
