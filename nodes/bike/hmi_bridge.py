"""The bike node's side of the web HMI (carlaverse.hmi): speed, power, cadence and grade.

The HMI thread reads the bike loop's shared state (its latest-value slot) at the frame rate.
The bike page only shows: the bridge takes no commands (the server's input check stops them).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from carlaverse.hmi.bridge import StateBridge


class BikeHmiBridge(StateBridge):
    kind = "bike"

    def _values(self, s: np.void) -> dict[str, Any]:
        return {
            "power_w": float(s["power_w"]),
            "cadence_rpm": float(s["cadence_rpm"]),
            "grade_percent": float(s["grade_percent"]),
            "resistance_percent": float(s["resistance_percent"]),
            "warnings": ["fallen"] if s["fallen"] else [],
        }
