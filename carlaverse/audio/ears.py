"""A live node's ears and its own engine, read each block from where the node keeps its pose.

A node kind that exports its state in shared memory (`own_pose_block()`: a seqlock block
with `t, x, y, yaw`, …) is read without network delay: a block with the head's own pose
(`eye_z`, `pitch`, `roll`: the walk node's tracked XR head) gives the ears directly; a
vehicle's pose gets the configured head offset. A block with `rpm` also gives the own
engine, from the powertrain's speed and the throttle as its load. A kind without a block is
heard at its own published pose (`ego/<id>/pose`, fed in by the audio process).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carlaverse import messages as m
from carlaverse.audio.config import ListenerConfig
from carlaverse.audio.listener import ListenerPose, ego_listener, yaw_rotation
from carlaverse.shm import BlockReader

OWN_ENGINE_ID = "own.engine"


@dataclass(frozen=True)
class BlockSpec:
    """The node's shared-memory state block: its name and record layout (picklable)."""

    name: str
    dtype: np.dtype


class Ears:
    """The listener pose and own sounds at render time `t`, from a block or a pose."""

    def __init__(self, listener: ListenerConfig, block: BlockSpec | None) -> None:
        self.config = listener
        self._reader = BlockReader(block.name, block.dtype) if block is not None else None
        self.pose: m.Pose | None = None  # the newest own published pose (no block)

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()

    def listener(self, t: float) -> ListenerPose | None:
        """Where the ears are, or None before the node has a pose."""
        record = self._read()
        if record is not None:
            return self._from_record(record, t)
        if self.pose is None:
            return None
        p = self.pose
        return ego_listener(p.x, p.y, p.yaw, (p.vx, p.vy), t, self.config.head_offset_m)

    def own_emitters(self, t: float) -> list[m.AudioEmitter]:
        """The node's own engine when its block reports rpm (a drive node), else none."""
        record = self._read()
        if record is None or "rpm" not in _names(record):
            return []
        yaw = float(record["yaw"])
        offset = yaw_rotation(yaw) @ np.asarray(self.config.engine_offset_m)
        load = float(record["throttle"]) if "throttle" in _names(record) else 0.5
        level = self.config.own_engine_level_db + 10.0 * math.log10(0.3 + 0.7 * load)
        return [m.AudioEmitter(
            OWN_ENGINE_ID, "engine", float(record["x"]) + offset[0],
            float(record["y"]) + offset[1], offset[2], float(record["vx"]), float(record["vy"]),
            0.0, level, drive_a=max(0.0, float(record["rpm"])), drive_b=min(1.0, max(0.0, load)),
        )]  # fmt: skip

    def _from_record(self, record: np.void, t: float) -> ListenerPose:
        names = _names(record)
        x, y, yaw = float(record["x"]), float(record["y"]), float(record["yaw"])
        velocity = (float(record["vx"]), float(record["vy"])) if "vx" in names else (0.0, 0.0)
        if "eye_z" not in names:
            return ego_listener(x, y, yaw, velocity, t, self.config.head_offset_m)
        rotation = yaw_rotation(yaw) @ _pitch(float(record["pitch"])) @ _roll(float(record["roll"]))
        position = np.array([x, y, float(record["eye_z"])])
        return ListenerPose(position, rotation, np.array([*velocity, 0.0]), t)

    def _read(self) -> np.void | None:
        return self._reader.read() if self._reader is not None else None


def _names(record: np.void) -> tuple[str, ...]:
    return record.dtype.names or ()


def _pitch(angle: float) -> np.ndarray:
    """Rotation about the head's y axis (left); positive tips the nose down (ISO 8855)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _roll(angle: float) -> np.ndarray:
    """Rotation about the head's x axis (forward)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
