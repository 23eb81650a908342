"""Motion-platform clients: what a node's motion cueing sends washout-filtered frames to.

Backends: `udp` (the paper's 21-byte FRAME_UPDATE to a motion server) and `sim` (records the
frames). Third parties add more under the entry-point group `carlaverse.hal.motion`.
"""

from __future__ import annotations

from carlaverse.hal import motion_packet
from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {
    "udp": BackendSpec("carlaverse.hal.motion.udp", "UdpMotion"),
    "sim": BackendSpec("carlaverse.hal.motion.sim", "SimMotion"),
}


class MotionConfig(DeviceConfig):
    """`motion:` block of a node config."""


class MotionDevice(Device):
    """Base class. `send` validates the frame (MotionPacketError if a value is not finite or
    over `limits`); `send_clipped` clips it to `limits` instead and never raises for a value,
    for a control loop; closing sends the neutral frame first."""

    limits = motion_packet.DEFAULT_LIMITS

    def send(self, frame: MotionFrame) -> None:
        """Command the platform to `frame` now."""
        self._send(frame, motion_packet.encode(frame, self.limits))

    def send_clipped(self, frame: MotionFrame) -> bool:
        """Command the platform to `frame` clipped to `limits`; True when a value was clipped."""
        inside, clipped = motion_packet.clip(frame, self.limits)
        self.send(inside)
        return clipped

    def neutral(self) -> None:
        """Command the rest pose."""
        self.send(NEUTRAL_FRAME)

    def close(self) -> None:
        if not self.closed:
            self.neutral()
        super().close()

    def _send(self, frame: MotionFrame, packet: bytes) -> None:
        raise NotImplementedError


def registry() -> Registry[MotionDevice]:
    return Registry("motion", MotionDevice, BACKENDS)
