"""Helpers for the drive tests: the shipped configs and input samples."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from carlaverse_nodes.drive.config import load_drive_config
from carlaverse_nodes.drive.vehicle_loop import DriveLoop, LoopOutput

from carlaverse.hal import InputState

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
DT = 0.001  # [s] 1 kHz


def desktop_loop(clock: Callable[[], float] | None = None) -> DriveLoop:
    config, vehicle = load_drive_config(CONFIGS / "drive-desktop.yaml")
    return DriveLoop(config, vehicle, clock=clock)


def keys(
    steer: float = 0.0, throttle: float = 0.0, brake: float = 0.0, *buttons: str
) -> InputState:
    """A keyboard-backend sample: the desktop config's channel names."""
    return InputState(0.0, {"steer": steer, "throttle": throttle, "brake": brake},
                      dict.fromkeys(buttons, True))  # fmt: skip


IDLE = keys()


def run(loop: DriveLoop, seconds: float, sample: InputState = IDLE) -> LoopOutput:
    out = None
    for _ in range(round(seconds / DT)):
        out = loop.step(DT, sample)
    assert out is not None
    return out


def tap(loop: DriveLoop, *buttons: str) -> LoopOutput:
    """Press and release buttons over two ticks; returns the pressing tick's output."""
    out = loop.step(DT, keys(0.0, 0.0, 0.0, *buttons))
    loop.step(DT, IDLE)
    return out
