"""How far a participant's view of the others was from the truth, now (issue 44.5).

A view sample is where a participant's world view drew another participant at session time
`t` (`carlaverse.study.view_probe`, which sees the session through that participant's link).
The truth is where the other actually was at `t`: their own pose stream as recorded, each
pose stamped by its sender with the session time it holds for, linearly interpolated to `t`.
The error is the horizontal distance between the two: what a participant sees against where
the other really is (bench_wan's "error vs now"), clock-sync error included.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import defaultdict
from pathlib import Path

import msgspec

from carlaverse import messages as m
from carlaverse.keys import KeySpaceError, parse_cached
from carlaverse.recording.reading import iter_samples

# (t [s] session time, x [m], y [m]) in time order
Track = list[tuple[float, float, float]]


class ViewSample(msgspec.Struct, frozen=True, array_like=True):
    t: float  # [s] session time the view was drawn for
    other: str  # the participant drawn
    x: float  # [m]
    y: float  # [m]


class ViewError(msgspec.Struct, frozen=True):
    """One participant's view of one other, over a trial."""

    samples: int
    p50_m: float
    p95_m: float
    max_m: float


def true_tracks(recording: Path, ids: set[str]) -> dict[str, Track]:
    """Each of `ids`' own pose stream in the recording, ordered by the pose's session time."""
    tracks: dict[str, Track] = defaultdict(list)
    for sample in iter_samples(recording):
        try:
            key = parse_cached(sample.key)
        except KeySpaceError:
            continue
        if key.area != "ego" or key.channel != "pose" or key.node_id not in ids:
            continue
        try:
            pose = m.POSE.decode(sample.payload)
        except m.MessageError:
            continue
        tracks[key.node_id].append((pose.t, pose.x, pose.y))
    return {node: sorted(track) for node, track in tracks.items()}


def position_at(track: Track, t: float) -> tuple[float, float] | None:
    """The track's position at `t`, linear between samples; None outside the track."""
    if not track or t < track[0][0] or t > track[-1][0]:
        return None
    i = bisect_left(track, (t, -math.inf, -math.inf))
    if track[i][0] == t or i == 0:
        return track[i][1], track[i][2]
    (t0, x0, y0), (t1, x1, y1) = track[i - 1], track[i]
    f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
    return x0 + f * (x1 - x0), y0 + f * (y1 - y0)


def view_errors(samples: list[ViewSample], truth: dict[str, Track]) -> dict[str, ViewError]:
    """Per other participant: the error of the view against the truth at the same time."""
    errors: dict[str, list[float]] = defaultdict(list)
    for s in samples:
        true = position_at(truth.get(s.other, []), s.t)
        if true is not None:
            errors[s.other].append(math.hypot(s.x - true[0], s.y - true[1]))
    return {other: summarise(values) for other, values in sorted(errors.items()) if values}


def summarise(values: list[float]) -> ViewError:
    ordered = sorted(values)
    return ViewError(len(ordered), _quantile(ordered, 0.5), _quantile(ordered, 0.95), ordered[-1])


def _quantile(ordered: list[float], q: float) -> float:
    """Linear interpolation between closest ranks (numpy's default, 'linear')."""
    position = q * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (position - low) * (ordered[high] - ordered[low])
