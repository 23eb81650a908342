"""Sends each command as the 40-byte packet to a `carlaverse ffb-server` (or the paper's C++
server), over a connected non-blocking UDP socket."""

from __future__ import annotations

import time

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.ffb import FfbDevice
from carlaverse.hal.ffb_packet import DEFAULT_FFB_PORT, FfbCommand
from carlaverse.hal.udp_client import UdpSender


class UdpFfbOptions(StrictStruct):
    host: str = "127.0.0.1"
    port: int = DEFAULT_FFB_PORT


class UdpFfb(FfbDevice):
    """Keep sending at the haptics rate: the server zeroes all forces when packets stop."""

    Options = UdpFfbOptions

    def __init__(self, options: UdpFfbOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.sender = UdpSender(options.host, options.port, clock, "FFB server")

    def _send(self, command: FfbCommand, packet: bytes) -> None:
        self.sender.send(packet)

    def _close(self) -> None:
        self.sender.close()
