"""The link emulator's old home: it is a supported part of the transport now
(`carlaverse.transport.link_emulator`, used by studies to give a participant's link delay,
jitter and loss); the WAN tests and tools that import it from here keep working."""

from carlaverse.transport.link_emulator import (
    CHUNK,
    RTO_MIN_S,
    TRACE_CHUNKS,
    Direction,
    LinkEmulator,
    LinkModel,
    LinkProfile,
    Transport,
)

__all__ = [
    "CHUNK",
    "RTO_MIN_S",
    "TRACE_CHUNKS",
    "Direction",
    "LinkEmulator",
    "LinkModel",
    "LinkProfile",
    "Transport",
]
