"""When a recording's session happened: the first pose, the offset between the recorder's
log time and the session clock, and the span a command's time must fall in.

A recorder stamps each sample with its own receive time (log time); the session's own time is
in each pose's publish time. The first pose gives the offset between the two, so a renderer or
a viewer can place any sample on the session clock.

People name a moment in seconds from the recording's start (its first sample), the number a
player's seek bar shows; the session clock is there for whoever reads it off a message.
`RecordingSpan.session_time` turns either into session time and refuses one outside the
recording with one line naming the valid range; every command that takes a time uses it.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader

from carlaverse import keys as keyspace
from carlaverse.recording.reading import RecordedSample, iter_samples
from carlaverse.recording.sink import RecordingError

SPAN_SLACK_S = 1e-6  # [s] a time printed from the span and typed back lies inside it


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
    (a recorder usually starts before the nodes, so this is before the first pose). The same
    as `recording_span(path).start`, without finding the end."""
    first = next(iter_samples(path), None)  # in ns until the end: 1e18 ns do not fit a float
    return (first.log_time_ns - receive_offset_ns(path)) / 1e9 if first else 0.0


class OutOfRange(ValueError):
    """A time outside the recording; the message names the valid range."""


@dataclass(frozen=True, slots=True)
class RecordingSpan:
    """From the recording's first sample to its last, on the session clock."""

    start: float  # [s] session time of the first sample
    end: float  # [s] session time of the last sample

    @property
    def duration(self) -> float:
        return self.end - self.start

    def valid(self) -> str:
        """The range in words, its end rounded down so what is printed lies inside."""
        return f"valid 0.0–{math.floor(self.duration * 10) / 10:.1f} s from start"

    def from_start(self, session_t: float) -> float:
        """[s] from the recording's start to the session time `session_t`."""
        return session_t - self.start

    def session_time(self, value: float, flag: str, *, session: bool = False) -> float:
        """The session time of `value` given to `flag`: seconds from the start (default) or,
        with `session`, a session time. OutOfRange names the valid range when it is outside."""
        if not math.isfinite(value):
            raise OutOfRange(f"{flag} {value}: give seconds, {self.valid()}")
        t = value if session else self.start + value
        if self.start - SPAN_SLACK_S <= t <= self.end + SPAN_SLACK_S:
            return t
        where = "past the recording's end" if t > self.end else "before the recording's start"
        valid = self.valid()
        if session:
            valid = f"valid {self.start:.3f}–{self.end:.3f} s session time ({valid})"
        raise OutOfRange(f"{flag} {value:g} s is {where}: {valid}")


def recording_span(path: str | Path) -> RecordingSpan:
    """The recording's span; from the file's summary when it is finished, else by reading it
    through (a killed recorder's file has no summary). Empty at 0 for a file without samples."""
    first, last = _log_span_ns(Path(path))
    offset = receive_offset_ns(path)
    return RecordingSpan((first - offset) / 1e9, (last - offset) / 1e9)


def _log_span_ns(path: Path) -> tuple[int, int]:
    try:
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
    except OSError as exc:
        raise RecordingError(f"cannot open recording {path}: {exc.strerror}") from exc
    except (McapError, ValueError, struct.error):
        summary = None
    stats = summary.statistics if summary is not None else None
    if stats is not None and stats.message_count > 0:
        return stats.message_start_time, stats.message_end_time
    first = last = None
    for sample in iter_samples(path):
        first = sample.log_time_ns if first is None else first
        last = sample.log_time_ns
    if first is None or last is None:
        return 0, 0  # nothing recorded: an empty span, which every time but 0 is outside
    return first, last
