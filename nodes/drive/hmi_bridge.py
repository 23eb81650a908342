"""The drive node's side of the web HMI (carlaverse.hmi): dashboard values out, taps and
cruise commands in.

Out: the HMI thread reads the control loop's shared state (its latest-value slot) at the
frame rate. In: validated commands wait on a queue until the node's step forwards them to
the loop's event queue — a tap as a `TouchPress` (a button for one tick, read by `Controls`
like any key), cruise set/resume/cancel as an `Override` from the source `hmi-cruise`, which
the loop's ADAS arbiter checks like one from the fabric.
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from typing import Any

from carlaverse_nodes.drive.controls import ACTIONS
from carlaverse_nodes.drive.shared_state import INDICATORS
from carlaverse_nodes.drive.touch import TouchPress
from carlaverse_nodes.loop_events import drain

from carlaverse.hmi.bridge import StateBridge
from carlaverse.hmi.wire import Command, Cruise, Press
from carlaverse.messages import Override
from carlaverse.physics.params import VehicleParams
from carlaverse.shm import SharedBlock
from carlaverse.transport.node_client import NodeSettings

CRUISE_SOURCE = "hmi-cruise"
REV_WARNING = 0.97  # of the redline
LATE_TICK_US = 2000.0  # [µs] a control tick this late is worth a warning
COLLISION_SHOWN_S = 3.0  # [s] the collision warning stays up this long


class DriveHmiBridge(StateBridge):
    kind = "drive"
    actions = frozenset(ACTIONS)
    cruise = True

    def __init__(
        self,
        settings: NodeSettings,
        vehicle: VehicleParams,
        state: Callable[[], SharedBlock | None],
    ) -> None:
        super().__init__(settings, state)
        self._commands: queue.SimpleQueue[Command] = queue.SimpleQueue()
        self._vehicle = vehicle
        self._cruise_seq = 0
        self._cruise_set_mps: float | None = None  # what `resume` goes back to
        self._impulses_seen = 0
        self._collision_until = 0.0  # monotonic [s]

    def static_info(self) -> dict[str, Any]:
        return {
            "redline_rpm": self._vehicle.engine.redline_rpm,
            "transmission": self._vehicle.transmission.mode,
        }

    def _values(self, s: Any) -> dict[str, Any]:
        return {
            "rpm": float(s["rpm"]),
            "gear": int(s["gear"]),
            "indicator": INDICATORS[int(s["indicator"])],
            "blink_on": bool(s["blink_on"]),
            "lights": int(s["lights"]),
            "adas_active": bool(s["adas_active"]),  # some override drives with the human
            "cruise_active": bool(s["cruise_active"]),
            "cruise_speed_mps": float(s["cruise_speed_mps"]),
            "throttle": float(s["throttle"]),
            "brake": float(s["brake"]),
            "warnings": self._warnings(s),
        }

    def _warnings(self, s: Any) -> list[str]:
        found = []
        if float(s["rpm"]) > REV_WARNING * self._vehicle.engine.redline_rpm:
            found.append("rev limit")
        if s["brake_override"]:
            found.append("brake overrides cruise")
        if int(s["impulses_applied"]) > self._impulses_seen:
            self._impulses_seen = int(s["impulses_applied"])
            self._collision_until = time.monotonic() + COLLISION_SHOWN_S
        if time.monotonic() < self._collision_until:
            found.append("collision")
        if float(s["period_error_us"]) > LATE_TICK_US:
            found.append("control loop late")
        return found

    def submit(self, command: Command) -> None:
        self._commands.put(command)

    def forward(self, events: Any, now: float, speed_mps: float) -> int:
        """Move the pages' commands onto the loop's event queue (node step); how many."""
        forwarded = 0
        for command in drain(self._commands):
            event = self._for_loop(command, now, speed_mps)
            if event is not None:
                events.put(event)
                forwarded += 1
        return forwarded

    def _for_loop(self, command: Command, now: float, speed_mps: float) -> Any:
        if isinstance(command, Press):
            return TouchPress(command.action)
        assert isinstance(command, Cruise)
        if command.command == "set":
            self._cruise_set_mps = max(0.0, speed_mps)
        elif command.command == "resume" and self._cruise_set_mps is None:
            return None  # nothing set yet: resume has nothing to go back to
        self._cruise_seq += 1
        if command.command == "cancel":
            return Override(self._cruise_seq, now, CRUISE_SOURCE, active=False)
        return Override(self._cruise_seq, now, CRUISE_SOURCE, cruise_speed_mps=self._cruise_set_mps)
