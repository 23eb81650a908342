"""A camera that sees a synthetic walker: landmarks always, a rendered frame on request.
Deterministic given the clock (cadence sets the gait phase)."""

from __future__ import annotations

import math
import time
from typing import Annotated

import msgspec
import numpy as np

from carlaverse.config import StrictStruct
from carlaverse.hal.camera import Camera, CameraFrame
from carlaverse.hal.camera.walker import project, walker_landmarks
from carlaverse.hal.device import Clock

Positive = Annotated[float, msgspec.Meta(gt=0)]
Pixels = Annotated[int, msgspec.Meta(ge=16, le=4096)]


class SimCameraOptions(StrictStruct):
    height_m: Positive = 1.75  # [m] walker's body height
    cadence_steps_per_min: Annotated[float, msgspec.Meta(ge=0)] = 100.0  # [1/min]
    hip_swing_rad: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.35  # [rad]
    render: bool = False  # also draw an RGB frame
    width: Pixels = 320  # [px]
    height: Pixels = 240  # [px]


class SimCamera(Camera):
    Options = SimCameraOptions

    def __init__(self, options: SimCameraOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.t0 = clock()

    def _read(self, now: float) -> CameraFrame:
        o = self.options
        stride_hz = o.cadence_steps_per_min / 120.0  # two steps per stride
        phase = 2 * math.pi * stride_hz * (now - self.t0)
        landmarks = walker_landmarks(phase, o.height_m, o.hip_swing_rad)
        image = self._render(landmarks) if o.render else None
        return CameraFrame(now, landmarks, np.ones(33, dtype=np.float32), image)

    def _render(self, landmarks: np.ndarray) -> np.ndarray:
        o = self.options
        image = np.zeros((o.height, o.width, 3), dtype=np.uint8)
        pixels = np.rint(project(landmarks, o.width, o.height, o.height_m)).astype(int)
        for u, v in pixels:
            image[max(0, v - 1) : v + 2, max(0, u - 1) : u + 2] = (255, 255, 255)
        return image
