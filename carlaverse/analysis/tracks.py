"""Every road user's trajectory in a recording, resampled onto one fixed time grid.

Humans come from their pose telemetry (`ego/<id>/pose`), NPCs from the authority's batches
(`world/npc`); both carry session time, position, heading and velocity, read in the one pass
over a recording the OSI export makes too (`recording/recorded_world.py`). Each actor is sampled
by linear interpolation on a grid common to all (so pair measures compare the same instants),
and is absent (NaN) before its first sample, after its last and across gaps longer than
`max_gap_s` — interpolating over a dropout would invent motion nobody saw.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from carlaverse import messages as m
from carlaverse.recording.recorded_world import COLUMN, Progress, RecordedWorld, read_world
from carlaverse.recording.timeline import recording_start_time

RESAMPLED = ("x", "y", "yaw", "vx", "vy")  # the columns of Tracks, in its order


@dataclass(frozen=True, slots=True)
class Actor:
    id: str
    kind: str  # one of messages.ACTOR_KINDS
    human: bool  # a participant's ego (True) or an NPC of the authority (False)
    length: float  # [m]
    width: float  # [m]


@dataclass(frozen=True)
class Tracks:
    """Actors x time; NaN where an actor is absent. Velocities are in the world frame."""

    t: np.ndarray  # (T,) session time [s]
    actors: list[Actor]
    x: np.ndarray  # (N, T) [m]
    y: np.ndarray  # (N, T) [m]
    yaw: np.ndarray  # (N, T) [rad]
    vx: np.ndarray  # (N, T) [m/s]
    vy: np.ndarray  # (N, T) [m/s]

    @property
    def present(self) -> np.ndarray:
        return ~np.isnan(self.x)

    def index(self, actor_id: str) -> int:
        return next(i for i, a in enumerate(self.actors) if a.id == actor_id)


@dataclass(frozen=True)
class Recording:
    """What one pass over a recording gives the analysis."""

    tracks: Tracks
    events: list[m.WorldEvent]  # every `world/events` message, in recorded order
    road_map: m.MapReply | None  # the first map reply kept, if any
    # [s] session time of the recording's first sample: what times are shown from, the
    # origin of `render --at` and `audio render --at` too (recording.timeline)
    start: float = 0.0


def read_tracks(
    path: str | Path,
    rate_hz: float = 10.0,
    max_gap_s: float = 0.5,
    progress: Progress | None = None,
) -> Tracks:
    """The recording's road users on a `rate_hz` grid spanning their samples."""
    return read_recording(path, rate_hz, max_gap_s, progress).tracks


def read_recording(
    path: str | Path,
    rate_hz: float = 10.0,
    max_gap_s: float = 0.5,
    progress: Progress | None = None,
) -> Recording:
    """Tracks, events and map of a recording, in one pass over it (recordings run to GBs)."""
    world = read_world(path, progress)
    start = recording_start_time(path)  # reads up to the first pose, not the file again
    return Recording(_tracks(world, rate_hz, max_gap_s), world.events, world.road_map, start)


def _tracks(world: RecordedWorld, rate_hz: float, max_gap_s: float) -> Tracks:
    ids = world.actor_ids()
    series = {a: world.rows(a) for a in ids}
    if not series:
        return Tracks(np.zeros(0), [], *(np.zeros((0, 0)) for _ in range(5)))
    start = min(rows[0, 0] for rows in series.values())
    end = max(rows[-1, 0] for rows in series.values())
    t = start + np.arange(int(np.floor((end - start) * rate_hz)) + 1) / rate_hz
    actors = [_actor(a, world) for a in ids]
    columns = np.stack([_resample(series[a], t, max_gap_s) for a in ids])  # (N, 5, T)
    return Tracks(t, actors, *(columns[:, c, :] for c in range(5)))


def _resample(rows: np.ndarray, t: np.ndarray, max_gap_s: float) -> np.ndarray:
    """(5, T): x, y, yaw, vx, vy at grid times, NaN outside the samples and across gaps."""
    times = rows[:, COLUMN["t"]]
    out = np.full((5, len(t)), np.nan)
    inside = (t >= times[0]) & (t <= times[-1])
    after = np.clip(np.searchsorted(times, t, side="left"), 1, max(1, len(times) - 1))
    if len(times) > 1:
        inside &= (times[after] - times[after - 1]) <= max_gap_s
    else:
        inside &= np.isclose(t, times[0])
    values = rows[:, [COLUMN[c] for c in RESAMPLED]]  # a copy: fancy indexing
    values[:, 2] = np.unwrap(values[:, 2])  # heading is interpolated the short way round
    for c in range(5):
        out[c, inside] = np.interp(t[inside], times, values[:, c])
    out[2] = np.angle(np.exp(1j * out[2]))  # back into (-pi, pi]
    return out


def _actor(actor_id: str, world: RecordedWorld) -> Actor:
    kind = world.kinds.get(actor_id, "other")
    extent = world.extents.get(actor_id) or m.KIND_EXTENTS.get(kind) or m.KIND_EXTENTS["other"]
    return Actor(actor_id, kind, actor_id in world.humans, extent.length, extent.width)
