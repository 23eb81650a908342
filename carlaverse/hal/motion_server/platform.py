"""Motion platforms: what the motion server drives.

The paper's server talks to the D-BOX LiveMotion SDK; ours keeps that seam as an interface so
a lab adds its vendor SDK without touching any client (they keep sending the same 21-byte
FRAME_UPDATE). To add one:

    class DboxPlatform(MotionPlatform):
        Options = DboxOptions                  # a StrictStruct: licence file, axis gains ...
        def __init__(self, options, *, clock): ...   # open the SDK session
        def _apply(self, frame, now): ...      # map roll/pitch/heave/rpm/torque to the rig
        def _neutral(self, now): ...           # drive the rig to its rest pose
        def _close(self): ...                  # neutral already sent; close the SDK

and register it in your package's pyproject.toml:

    [project.entry-points."carlaverse.hal.motion_server"]
    dbox = "lab_dbox:DboxPlatform"

then run `carlaverse motion-server --backend dbox -o licence=...`. Frames arrive already
validated against `MotionLimits` and washout-filtered by the client; the server owns the
watchdog, so `_neutral` is called when frames stop and when the server ends.

Built in: `log` (logs frames at INFO, so `--verbose` shows them) and `csv`.
"""

from __future__ import annotations

import collections
import logging
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock, Device
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame
from carlaverse.hal.registry import BackendSpec, Registry

log = logging.getLogger(__name__)

BACKENDS = {
    "log": BackendSpec("carlaverse.hal.motion_server.platform", "LogPlatform"),
    "csv": BackendSpec("carlaverse.hal.motion_server.csv_platform", "CsvPlatform"),
}


class MotionPlatform(Device):
    """Base class: `apply` per valid frame, `neutral` on watchdog and on stop."""

    def apply(self, frame: MotionFrame, now: float) -> None:
        """Move the platform to `frame`; `now` is the server clock [s]."""
        self._apply(frame, now)

    def neutral(self, now: float) -> None:
        """Return the platform to its rest pose and silence engine effects."""
        self._neutral(now)

    def _apply(self, frame: MotionFrame, now: float) -> None:
        raise NotImplementedError

    def _neutral(self, now: float) -> None:
        self._apply(NEUTRAL_FRAME, now)


def registry() -> Registry[MotionPlatform]:
    return Registry("motion_server", MotionPlatform, BACKENDS)


class LogPlatformOptions(StrictStruct):
    history: Annotated[int, msgspec.Meta(ge=1)] = 100_000  # events kept for inspection


class PlatformEvent(msgspec.Struct, frozen=True):
    t: float  # [s] server clock
    kind: str  # "frame" or "neutral"
    frame: MotionFrame


class LogPlatform(MotionPlatform):
    """Logs every frame (INFO) and keeps the events; `current` is the pose now commanded."""

    Options = LogPlatformOptions

    def __init__(self, options: LogPlatformOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.events: collections.deque[PlatformEvent] = collections.deque(maxlen=options.history)
        self.current = NEUTRAL_FRAME

    def _apply(self, frame: MotionFrame, now: float) -> None:
        self.current = frame
        self.events.append(PlatformEvent(now, "frame", frame))
        log.info(
            "frame roll=%.4f rad pitch=%.4f rad heave=%.4f m rpm=%.0f torque=%.1f N·m",
            *msgspec.structs.astuple(frame),
        )

    def _neutral(self, now: float) -> None:
        self.current = NEUTRAL_FRAME
        self.events.append(PlatformEvent(now, "neutral", NEUTRAL_FRAME))
        log.info("platform to neutral")

    def frames(self) -> list[MotionFrame]:
        """The frames applied so far, in order (neutral events not included)."""
        return [event.frame for event in list(self.events) if event.kind == "frame"]
