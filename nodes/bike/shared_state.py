"""The bike node's shared-memory layout (see the drive node's for the pattern).

`STATE` is written by the loop process every tick, read by the fabric process (pose,
a future HMI page: speed, power, cadence, grade). `CONTROL` is written by the fabric process:
the session-clock offset, the spawn pose, the authority's wind and the road's grade at the
bike (from the scenario, looked up by the fabric process at its step rate). `roll` is the
pose's: ISO 8855, right side down positive, so a bike leaning left has roll < 0.
"""

from __future__ import annotations

import numpy as np

STATE = np.dtype(
    [
        ("t", "<f8"), ("x", "<f8"), ("y", "<f8"), ("yaw", "<f8"), ("roll", "<f8"),
        ("vx", "<f8"), ("vy", "<f8"), ("yaw_rate", "<f8"), ("ax", "<f8"), ("ay", "<f8"),
        ("speed_mps", "<f8"), ("steer_rad", "<f8"),
        ("power_w", "<f8"), ("cadence_rpm", "<f8"), ("grade_percent", "<f8"),
        ("resistance_n", "<f8"), ("resistance_percent", "<f8"), ("fallen", "u1"),
        ("trainer_limit", "u1"), ("trainer_missing_n", "<f8"),  # what it cannot render
        ("ticks", "<u8"), ("ffb_sent", "<u8"), ("impulses_applied", "<u8"),
        ("running", "u1"),
        ("written_ns", "<u8"),  # [ns] host monotonic clock at the write (a view's latency)
    ]
)  # fmt: skip

CONTROL = np.dtype(
    [
        ("clock_offset", "<f8"),  # [s] session time = monotonic + this
        ("spawn_seq", "<u4"), ("spawn_x", "<f8"), ("spawn_y", "<f8"), ("spawn_yaw", "<f8"),
        ("wind_speed_mps", "<f8"), ("wind_from_deg", "<f8"),  # the authority's weather
        ("grade_percent", "<f8"),  # [%] felt along the heading, uphill positive
    ]
)  # fmt: skip
