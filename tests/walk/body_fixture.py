"""A skeleton source for tests (`body: {source: "tests.walk.body_fixture:make"}`): a head that
nods, one result per frame of a `rate_hz` camera; `poll` hands out the newest frame not yet
handed out, as a camera pipeline does (frames between two polls are dropped)."""

from __future__ import annotations

import math
import struct
import time
from collections.abc import Mapping
from typing import Any

from carlaverse.messages import Skeleton


class NoddingHead:
    def __init__(self, rate_hz: float) -> None:
        self.period_s = 1.0 / rate_hz
        self.t0 = time.monotonic()
        self.last_frame = -1
        self.closed = False

    def poll(self) -> Skeleton | None:
        frame = int((time.monotonic() - self.t0) / self.period_s)
        if frame == self.last_frame:
            return None
        self.last_frame = frame
        now = self.t0 + frame * self.period_s  # [s] the frame's capture time
        pitch = 0.3 * math.sin(now)  # [rad]
        angles = struct.pack("<6f", 0.0, pitch, 0.0, 0.0, 0.0, 0.5)
        return Skeleton(0, now, ["neck", "left_elbow"], angles)

    def close(self) -> None:
        self.closed = True


def make(options: Mapping[str, Any]) -> NoddingHead:
    return NoddingHead(float(options.get("rate_hz", 30.0)))
