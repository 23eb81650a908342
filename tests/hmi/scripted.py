"""A node side for HMI tests that run the server in this process: telemetry set by the test,
commands recorded (the server, sockets and browser around it are real)."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from carlaverse.hmi.config import load_hmi_config
from carlaverse.hmi.server import HmiServer
from carlaverse.hmi.wire import Command


class ScriptedBridge:
    kind = "drive"
    node_id = "scripted-car"
    actions = frozenset({"low_beam", "gear_drive"})
    cruise = True
    torn_reads = 0

    def __init__(self, **values: Any) -> None:
        self.values: dict[str, Any] = {
            "speed_mps": 0.0, "rpm": 900.0, "gear": 0, "indicator": "off", "blink_on": False,
            "lights": 0, "adas_active": False, "cruise_active": False, "cruise_speed_mps": 0.0,
            "warnings": [], **values,
        }  # fmt: skip
        self.commands: list[Command] = []
        self._lock = threading.Lock()

    def static_info(self) -> dict[str, Any]:
        return {"redline_rpm": 6500.0, "transmission": "automatic"}

    def telemetry(self) -> tuple[float, dict[str, Any]] | None:
        return time.monotonic(), dict(self.values)

    def submit(self, command: Command) -> None:
        with self._lock:
            self.commands.append(command)

    def close(self) -> None:
        pass


@contextmanager
def serving(bridge: ScriptedBridge, folder: Path, config_yaml: str) -> Iterator[HmiServer]:
    config = folder / "hmi.yaml"
    config.write_text(config_yaml)
    server = HmiServer(bridge, load_hmi_config(str(config))).start()
    try:
        yield server
    finally:
        server.close()
