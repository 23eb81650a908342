"""The drive node's shared-memory layout: what the 1 kHz loop tells the fabric, and back.

`STATE` is written by the loop process every tick and read by the fabric process (pose
telemetry, ego state, the dashboard of a web HMI). `CONTROL` is written by the fabric process:
the session-clock offset (so the loop stamps session time without any network) and the spawn
pose granted at join. Events — impulses, overrides — travel on a queue, never through here.
Blocks are named by `carlaverse.shm.block_name` (`carlaverse-<session>-<node id>-state|control`)
so an HMI can attach.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from carlaverse.messages import Indicator

INDICATORS: tuple[Indicator, ...] = ("off", "left", "right", "hazard")

STATE = np.dtype(
    [
        ("t", "<f8"),  # [s] session time of the tick
        ("x", "<f8"), ("y", "<f8"), ("yaw", "<f8"),  # [m, m, rad]
        ("vx", "<f8"), ("vy", "<f8"), ("yaw_rate", "<f8"),  # world frame [m/s, rad/s]
        ("ax", "<f8"), ("ay", "<f8"),  # [m/s²]
        ("speed_mps", "<f8"), ("steer_rad", "<f8"), ("rpm", "<f8"), ("engine_torque_nm", "<f8"),
        ("throttle", "<f8"), ("brake", "<f8"),
        ("gear", "<i4"), ("lights", "<u4"), ("indicator", "u1"), ("blink_on", "u1"),
        ("lca_active", "u1"), ("adas_active", "u1"),
        ("cruise_active", "u1"), ("cruise_speed_mps", "<f8"), ("brake_override", "u1"),
        ("ticks", "<u8"), ("period_error_us", "<f8"), ("max_period_error_us", "<f8"),
        ("ffb_sent", "<u8"), ("motion_sent", "<u8"), ("impulses_applied", "<u8"),
        ("running", "u1"),
        ("written_ns", "<u8"),  # [ns] host monotonic clock at the write (a view's latency)
    ]
)  # fmt: skip

CONTROL = np.dtype(
    [
        ("clock_offset", "<f8"),  # [s] session time = monotonic + this
        ("spawn_seq", "<u4"),  # bumped when a new spawn pose is granted
        ("spawn_x", "<f8"), ("spawn_y", "<f8"), ("spawn_yaw", "<f8"),
    ]
)  # fmt: skip
