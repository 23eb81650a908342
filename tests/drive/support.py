"""Helpers for the drive tests: the shipped configs, input samples, the real loop in-process."""

from __future__ import annotations

import functools
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from carlaverse_nodes.drive.config import DriveNodeConfig, load_drive_config
from carlaverse_nodes.drive.loop_process import LoopSpec, run_loop
from carlaverse_nodes.drive.shared_state import CONTROL, STATE
from carlaverse_nodes.drive.vehicle_loop import DriveLoop, LoopOutput
from carlaverse_nodes.loop_host import LoopHost

from carlaverse.hal import InputState
from carlaverse.physics.params import VehicleParams

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


def run_real_loop(config: DriveNodeConfig, vehicle: VehicleParams, seconds: float,
                  events: Sequence[object] = ()) -> tuple[dict[str, Any], int | None]:  # fmt: skip
    """Run the node's own control loop (`loop_process.run_loop`: devices, pacing, its own
    process, as the drive node starts it) for `seconds`, with `events` on its queue from the
    start; return its summary and its process's exit code."""
    host = LoopHost(STATE, CONTROL, "test loop")
    spec = functools.partial(LoopSpec, config, vehicle, duration_s=seconds)
    host._start_loop(f"t{uuid.uuid4().hex[:8]}", "car", run_loop, spec, clock_offset=0.0)
    for event in events:
        host._events.put(event)
    process = host._process
    process.join(timeout=seconds + 60)  # it ends by itself after `seconds`
    host._stop_loop()
    return host._loop_summary, process.exitcode
