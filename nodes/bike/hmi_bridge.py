"""The bike node's side of the web HMI (carlaverse.hmi): speed, power, cadence and grade.

The HMI thread reads the bike loop's shared state (its latest-value slot) at the frame rate.
The bike page only shows: the bridge takes no commands.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from carlaverse.fabric.node_client import NodeSettings
from carlaverse.hmi.bridge import StateReader
from carlaverse.hmi.wire import Command
from carlaverse.shm import SharedBlock


class BikeHmiBridge:
    kind = "bike"
    actions: frozenset[str] = frozenset()
    cruise = False

    def __init__(self, settings: NodeSettings, state: Callable[[], SharedBlock | None]) -> None:
        self.node_id = settings.node_id
        self._reader = StateReader(state)
        self.clock_offset = 0.0  # [s] session time − monotonic, kept by the node's step

    def static_info(self) -> dict[str, Any]:
        return {}

    def telemetry(self) -> tuple[float, dict[str, Any]] | None:
        s = self._reader.read()
        if s is None:
            return None
        values = {
            "t": float(s["t"]),  # [s] session time of the loop tick, as in its poses
            "speed_mps": float(s["speed_mps"]),
            "power_w": float(s["power_w"]),
            "cadence_rpm": float(s["cadence_rpm"]),
            "grade_percent": float(s["grade_percent"]),
            "resistance_percent": float(s["resistance_percent"]),
            "warnings": ["fallen"] if s["fallen"] else [],
        }
        return float(s["t"]) - self.clock_offset, values

    def submit(self, command: Command) -> None:
        raise ValueError(
            f"the bike HMI takes no commands, got {command!r}"
        )  # InputCheck stops them

    def close(self) -> None:
        pass  # the node owns and closes its state block
