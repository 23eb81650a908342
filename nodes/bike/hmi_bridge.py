"""The bike node's side of the web HMI (carlaverse.hmi): speed, power, cadence and grade, and a
notice while the trainer cannot render the ride.

The HMI thread reads the bike loop's shared state (its latest-value slot) at the frame rate.
The bike page only shows: the bridge takes no commands (the server's input check stops them).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from carlaverse_nodes.bike.trainer_command import TrainerLimit

from carlaverse.hmi.bridge import StateBridge


def trainer_notice(limit: TrainerLimit, missing_n: float) -> str:
    """One line for the rider: what the trainer is not rendering now ("" when it renders all)."""
    if limit is TrainerLimit.TOO_STEEP:
        return f"trainer at 100 %: {missing_n:.0f} N of the climb not felt"
    if limit is TrainerLimit.CANNOT_PUSH:
        return "trainer cannot push: the descent or tailwind is not felt"
    if limit is TrainerLimit.TOO_LIGHT:
        return "trainer slows faster than the bike would"
    return ""


class BikeHmiBridge(StateBridge):
    kind = "bike"

    def _values(self, s: np.void) -> dict[str, Any]:
        limit = TrainerLimit(int(s["trainer_limit"]))
        missing = float(s["trainer_missing_n"])
        notice = trainer_notice(limit, missing)
        return {
            "power_w": float(s["power_w"]),
            "cadence_rpm": float(s["cadence_rpm"]),
            "grade_percent": float(s["grade_percent"]),
            "resistance_percent": float(s["resistance_percent"]),
            "trainer_limit": limit.name.lower() if limit else "",
            "trainer_missing_n": missing,  # [N] the force the rider should feel and does not
            "warnings": (["fallen"] if s["fallen"] else []) + ([notice] if notice else []),
        }
