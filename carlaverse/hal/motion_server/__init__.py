"""The motion-platform server: FRAME_UPDATE packets in, platform motion out, with a watchdog."""

from carlaverse.hal.motion_server.platform import LogPlatform, MotionPlatform, registry
from carlaverse.hal.motion_server.server import DEFAULT_WATCHDOG_S, MotionServer, MotionServerStats

__all__ = [
    "DEFAULT_WATCHDOG_S",
    "LogPlatform",
    "MotionPlatform",
    "MotionServer",
    "MotionServerStats",
    "registry",
]
