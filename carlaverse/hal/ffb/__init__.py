"""Force-feedback clients: what a node's haptics loop sends its FFB commands to.

Backends: `udp` (the paper's 40-byte packet to an FFB server) and `sim` (records what it would
apply, for headless nodes and tests). Third parties add more under the entry-point group
`carlaverse.hal.ffb`.
"""

from __future__ import annotations

from carlaverse.hal import ffb_packet
from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.ffb_packet import ZERO_COMMAND, FfbCommand
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {
    "udp": BackendSpec("carlaverse.hal.ffb.udp", "UdpFfb"),
    "sim": BackendSpec("carlaverse.hal.ffb.sim", "SimFfb"),
}


class FfbConfig(DeviceConfig):
    """`ffb:` block of a node config."""


class FfbDevice(Device):
    """Base class. `send` validates the command (FfbPacketError if a field is out of range);
    closing zeroes every force first."""

    def send(self, command: FfbCommand) -> None:
        """Apply `command` now (it replaces the previous one entirely)."""
        self._send(command, ffb_packet.encode(command))

    def zero(self) -> None:
        """Remove every force."""
        self.send(ZERO_COMMAND)

    def close(self) -> None:
        if not self.closed:
            self.zero()
        super().close()

    def _send(self, command: FfbCommand, packet: bytes) -> None:
        raise NotImplementedError


def registry() -> Registry[FfbDevice]:
    return Registry("ffb", FfbDevice, BACKENDS)
