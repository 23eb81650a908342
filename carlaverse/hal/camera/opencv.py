"""A real camera (webcam, capture card, video file) through OpenCV's VideoCapture.

A grabber thread reads frames as the camera delivers them and keeps only the newest, so a
reader that is slower than the camera never works on stale, buffered frames; `read()` waits
for a frame newer than the last one it returned. A camera that cannot be opened, or sends
nothing within `frame_timeout_s`, is a `DeviceError` in one line.
"""

from __future__ import annotations

import threading
import time
from typing import Annotated

import cv2
import msgspec
import numpy as np

from carlaverse.config import StrictStruct
from carlaverse.hal.camera import Camera, CameraFrame
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError

Pixels = Annotated[int, msgspec.Meta(ge=16, le=4096)]


class OpenCvCameraOptions(StrictStruct):
    device: int | str = 0  # camera index (/dev/videoN) or a video file / stream URL
    width: Pixels = 640  # [px] requested; the camera may pick its nearest mode
    height: Pixels = 480  # [px]
    fps: Annotated[float, msgspec.Meta(gt=0, le=240)] = 30.0  # [1/s] requested
    frame_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 5.0  # [s]


def _describe(device: int | str) -> str:
    return f"camera /dev/video{device}" if isinstance(device, int) else f"video source {device!r}"


def _open_quietly(device: int | str) -> cv2.VideoCapture:
    """Open without OpenCV's own warnings: an absent camera is reported once, by us."""
    logging = cv2.utils.logging
    level = logging.getLogLevel()
    logging.setLogLevel(logging.LOG_LEVEL_SILENT)
    try:
        return cv2.VideoCapture(device)
    finally:
        logging.setLogLevel(level)


class OpenCvCamera(Camera):
    Options = OpenCvCameraOptions

    def __init__(self, options: OpenCvCameraOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self._capture = _open_quietly(options.device)
        if not self._capture.isOpened():
            fix = "check camera.options.device or use backend: sim"
            raise DeviceError(f"{_describe(options.device)} cannot be opened (no such device, "
                              f"or busy); {fix}")  # fmt: skip
        self._capture.set(cv2.CAP_PROP_FRAME_WIDTH, options.width)
        self._capture.set(cv2.CAP_PROP_FRAME_HEIGHT, options.height)
        self._capture.set(cv2.CAP_PROP_FPS, options.fps)
        self._newest: CameraFrame | None = None
        self._returned: CameraFrame | None = None
        self._fresh = threading.Condition()
        self._stop = threading.Event()
        self._grabber = threading.Thread(target=self._grab, name="camera-grabber", daemon=True)
        self._grabber.start()

    def _grab(self) -> None:
        while not self._stop.is_set():
            ok, bgr = self._capture.read()
            if not ok:
                break  # unplugged, or the end of a file
            frame = CameraFrame(self.clock(), None, None, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            with self._fresh:
                self._newest = frame
                self._fresh.notify_all()
        with self._fresh:
            self._stop.set()
            self._fresh.notify_all()

    def _read(self, now: float) -> CameraFrame:
        deadline = now + self.options.frame_timeout_s
        with self._fresh:
            while self._newest is self._returned and not self._stop.is_set():
                if not self._fresh.wait(max(0.0, deadline - self.clock())):
                    break
            if self._newest is self._returned:
                raise DeviceError(self._why_no_frame())
            frame = self._returned = self._newest
            assert frame is not None  # it is not `_returned`, which starts as None
            return frame

    def _why_no_frame(self) -> str:
        source = _describe(self.options.device)
        if self._stop.is_set():
            return f"{source} ended (unplugged, or the end of the file)"
        return f"{source} sent no new frame within {self.options.frame_timeout_s:g} s"

    def _close(self) -> None:
        self._stop.set()
        self._grabber.join(timeout=2.0)
        self._capture.release()


def letterbox(rgb: np.ndarray, width: int, height: int) -> np.ndarray:
    """`rgb` scaled to fit `width`×`height` [px] without distortion, on black."""
    h, w = rgb.shape[:2]
    scale = min(width / w, height / h)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    scaled = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
    out = np.zeros((height, width, 3), dtype=np.uint8)
    top, left = (height - size[1]) // 2, (width - size[0]) // 2
    out[top : top + size[1], left : left + size[0]] = scaled
    return out
