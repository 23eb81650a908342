"""The force-feedback server: UDP packets in, device effects out, with a safety watchdog."""

from carlaverse.hal.ffb_server.actuator import ForceActuator, LogActuator, registry
from carlaverse.hal.ffb_server.server import DEFAULT_WATCHDOG_S, FfbServer, FfbServerStats

__all__ = [
    "DEFAULT_WATCHDOG_S",
    "FfbServer",
    "FfbServerStats",
    "ForceActuator",
    "LogActuator",
    "registry",
]
