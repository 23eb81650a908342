"""A force-feedback device that applies nothing and remembers everything it was told."""

from __future__ import annotations

import collections
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.ffb import FfbDevice
from carlaverse.hal.ffb_packet import ZERO_COMMAND, FfbCommand


class SimFfbOptions(StrictStruct):
    history: Annotated[int, msgspec.Meta(ge=1)] = 10_000  # commands kept


class SimFfb(FfbDevice):
    """`current` is the force in effect; `history` holds (clock time [s], command)."""

    Options = SimFfbOptions

    def __init__(self, options: SimFfbOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.current = ZERO_COMMAND
        self.history: collections.deque[tuple[float, FfbCommand]] = collections.deque(
            maxlen=options.history
        )

    def _send(self, command: FfbCommand, packet: bytes) -> None:
        self.current = command
        self.history.append((self.clock(), command))
