"""Sends each frame as the 21-byte FRAME_UPDATE to a `carlaverse motion-server` (or the
paper's C++ server) over a connected non-blocking UDP socket."""

from __future__ import annotations

import time

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.motion import MotionDevice
from carlaverse.hal.motion_packet import DEFAULT_MOTION_PORT, MotionFrame, MotionLimits
from carlaverse.hal.udp_client import UdpSender


class UdpMotionOptions(StrictStruct):
    host: str = "127.0.0.1"
    port: int = DEFAULT_MOTION_PORT
    limits: MotionLimits = msgspec.field(default_factory=MotionLimits)


class UdpMotion(MotionDevice):
    Options = UdpMotionOptions

    def __init__(self, options: UdpMotionOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.limits = options.limits
        self.sender = UdpSender(options.host, options.port, clock, "motion server")

    def _send(self, frame: MotionFrame, packet: bytes) -> None:
        self.sender.send(packet)

    def _close(self) -> None:
        self.sender.close()
