"""A still picture as a camera: every read returns it as a new frame, letterboxed to the size
asked for. Drives the body-pose pipeline in tests and benchmarks with a real photograph."""

from __future__ import annotations

import time
from pathlib import Path

import cv2

from carlaverse.config import StrictStruct
from carlaverse.hal.camera import Camera, CameraFrame
from carlaverse.hal.camera.opencv import Pixels, letterbox
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError


class StillCameraOptions(StrictStruct):
    path: str  # an image file OpenCV reads (PNG, JPEG, ...)
    width: Pixels = 640  # [px]
    height: Pixels = 480  # [px]


class StillCamera(Camera):
    Options = StillCameraOptions

    def __init__(self, options: StillCameraOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        bgr = cv2.imread(str(Path(options.path).expanduser()))
        if bgr is None:
            raise DeviceError(f"still camera: {options.path} is not a readable image; "
                              f"check camera.options.path")  # fmt: skip
        rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        self.image = letterbox(rgb, options.width, options.height)

    def _read(self, now: float) -> CameraFrame:
        return CameraFrame(now, None, None, self.image)
