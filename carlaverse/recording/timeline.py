"""When a recording's session happened: the first pose, and the offset between the recorder's
log time and the session clock.

A recorder stamps each sample with its own receive time (log time); the session's own time is
in each pose's publish time. The first pose gives the offset between the two, so a renderer or
a viewer can place any sample on the session clock.
"""

from __future__ import annotations

from pathlib import Path

from carlaverse import keys as keyspace
from carlaverse.recording.reading import RecordedSample, iter_samples


def first_pose(path: str | Path) -> RecordedSample | None:
    for sample in iter_samples(path):
        if sample.kind == "put" and _is_pose(sample.key):
            return sample
    return None


def _is_pose(key: str) -> bool:
    try:
        return keyspace.parse(key).channel == "pose"
    except keyspace.KeySpaceError:
        return False


def first_pose_time(path: str | Path) -> float:
    """Session time [s] of the first recorded pose (0 when there is none)."""
    sample = first_pose(path)
    return sample.publish_time_ns / 1e9 if sample else 0.0


def receive_offset_ns(path: str | Path) -> int:
    """[ns] the recorder's log time minus session time, from the first pose (0 without one:
    the log time is all there is)."""
    pose = first_pose(path)
    return pose.log_time_ns - pose.publish_time_ns if pose else 0


def recording_start_time(path: str | Path) -> float:
    """Session time [s] at which the recording starts: when its first sample was received
    (a recorder usually starts before the nodes, so this is before the first pose)."""
    first = next(iter_samples(path), None)  # in ns until the end: 1e18 ns do not fit a float
    return (first.log_time_ns - receive_offset_ns(path)) / 1e9 if first else 0.0
