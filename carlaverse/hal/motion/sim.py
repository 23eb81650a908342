"""A motion platform that moves nothing and remembers every frame."""

from __future__ import annotations

import collections
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.motion import MotionDevice
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame, MotionLimits


class SimMotionOptions(StrictStruct):
    history: Annotated[int, msgspec.Meta(ge=1)] = 10_000  # frames kept
    limits: MotionLimits = msgspec.field(default_factory=MotionLimits)


class SimMotion(MotionDevice):
    """`current` is the commanded pose; `history` holds (clock time [s], frame)."""

    Options = SimMotionOptions

    def __init__(self, options: SimMotionOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.limits = options.limits
        self.current = NEUTRAL_FRAME
        self.history: collections.deque[tuple[float, MotionFrame]] = collections.deque(
            maxlen=options.history
        )

    def _send(self, frame: MotionFrame, packet: bytes) -> None:
        self.current = frame
        self.history.append((self.clock(), frame))
