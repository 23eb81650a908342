"""XR headsets: where the participant's head is, for the renderer's camera.

Backends: `sim` (a seated head that looks around) now; OpenXR comes with the nodes that
render in VR. Third parties add more under the entry-point group `carlaverse.hal.xr`.

Frame: x right, y up, z backwards (OpenXR's stage space), metres; orientation a unit
quaternion (w, x, y, z).
"""

from __future__ import annotations

import msgspec

from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {"sim": BackendSpec("carlaverse.hal.xr.sim", "SimHeadset")}


class XrConfig(DeviceConfig):
    """`xr:` block of a node config."""


class HeadPose(msgspec.Struct, frozen=True):
    t: float  # [s] device clock
    position: tuple[float, float, float]  # [m]
    orientation: tuple[float, float, float, float]  # unit quaternion (w, x, y, z)
    tracked: bool = True  # False when tracking is lost; the pose is then the last good one


class XrHeadset(Device):
    """Base class: `pose` samples the head now."""

    def pose(self) -> HeadPose:
        now = self.clock()
        position, orientation, tracked = self._pose(now)
        return HeadPose(now, position, orientation, tracked)

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        raise NotImplementedError


def registry() -> Registry[XrHeadset]:
    return Registry("xr", XrHeadset, BACKENDS)
