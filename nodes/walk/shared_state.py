"""The walk node's shared-memory layout (see the drive node's for the pattern).

`STATE` is written by the loop process every tick and read by the fabric process (the pose)
and by a `--view` render process (the first-person camera: the head's position and angles,
and each eye's frustum when the headset reports it).
`CONTROL` is written by the fabric process: the session-clock offset and the spawn pose.
"""

from __future__ import annotations

import numpy as np

STATE = np.dtype(
    [
        ("t", "<f8"),  # [s] session time
        ("x", "<f8"), ("y", "<f8"),  # [m] the walker (under the head) in the world
        ("eye_z", "<f8"),  # [m] eye height above the ground
        ("yaw", "<f8"), ("pitch", "<f8"), ("roll", "<f8"),  # [rad] the head, ISO 8855
        ("vx", "<f8"), ("vy", "<f8"), ("ax", "<f8"), ("ay", "<f8"),  # locomotion [m/s, m/s²]
        ("speed_mps", "<f8"), ("distance_m", "<f8"),
        ("stage_x", "<f8"), ("stage_y", "<f8"), ("stage_yaw", "<f8"),
        ("running_pace", "u1"), ("interact", "u1"), ("tracked", "u1"),
        ("ticks", "<u8"), ("snaps", "<u8"),
        ("running", "u1"),
        # the headset's eyes as it reports them [rad] (names: `shm_layouts.EYES, EDGES`)
        ("eyes", "u1"),
        ("left_eye_left", "<f8"), ("left_eye_right", "<f8"),
        ("left_eye_up", "<f8"), ("left_eye_down", "<f8"),
        ("right_eye_left", "<f8"), ("right_eye_right", "<f8"),
        ("right_eye_up", "<f8"), ("right_eye_down", "<f8"),
        ("written_ns", "<u8"),  # [ns] host monotonic clock at the write (a view's latency)
    ]
)  # fmt: skip

CONTROL = np.dtype(
    [
        ("clock_offset", "<f8"),  # [s] session time = monotonic + this
        ("spawn_seq", "<u4"), ("spawn_x", "<f8"), ("spawn_y", "<f8"), ("spawn_yaw", "<f8"),
    ]
)  # fmt: skip
