"""Every road user's trajectory in a recording, resampled onto one fixed time grid.

Humans come from their pose telemetry (`ego/<id>/pose`), NPCs from the authority's batches
(`world/npc`); both carry session time, position, heading and velocity. Each actor is sampled
by linear interpolation on a grid common to all (so pair measures compare the same instants),
and is absent (NaN) before its first sample, after its last and across gaps longer than
`max_gap_s` — interpolating over a dropout would invent motion nobody saw.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.recording.reading import iter_samples
from carlaverse.recording.timeline import recording_start_time

Progress = Callable[[int], None]  # called with the number of samples read so far


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


@dataclass
class _Raw:
    """What one pass over the recording collected, before resampling."""

    samples: dict[str, list[np.ndarray]]  # id -> rows of (t, x, y, yaw, vx, vy)
    kinds: dict[str, str]
    extents: dict[str, m.Extent]
    humans: set[str]
    events: list[m.WorldEvent] = field(default_factory=list)
    road_map: m.MapReply | None = None
    read: int = 0
    skipped: int = 0


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
    raw = _collect(Path(path), progress)
    start = recording_start_time(path)  # reads up to the first pose, not the file again
    return Recording(_tracks(raw, rate_hz, max_gap_s), raw.events, raw.road_map, start)


def _tracks(raw: _Raw, rate_hz: float, max_gap_s: float) -> Tracks:
    series = {k: _sorted_rows(v) for k, v in raw.samples.items() if v}
    if not series:
        return Tracks(np.zeros(0), [], *(np.zeros((0, 0)) for _ in range(5)))
    start = min(rows[0, 0] for rows in series.values())
    end = max(rows[-1, 0] for rows in series.values())
    t = start + np.arange(int(np.floor((end - start) * rate_hz)) + 1) / rate_hz
    ids = sorted(series, key=lambda a: (a not in raw.humans, a))
    actors = [_actor(a, raw) for a in ids]
    columns = np.stack([_resample(series[a], t, max_gap_s) for a in ids])  # (N, 5, T)
    return Tracks(t, actors, *(columns[:, c, :] for c in range(5)))


def _collect(path: Path, progress: Progress | None) -> _Raw:
    raw = _Raw(defaultdict(list), {}, {}, set())
    for sample in iter_samples(path):
        raw.read += 1
        if progress and raw.read % 10000 == 0:
            progress(raw.read)
        if sample.kind != "put":
            continue
        try:
            _take(raw, keyspace.parse(sample.key), sample.payload)
        except (keyspace.KeySpaceError, m.MessageError):
            raw.skipped += 1  # a foreign or damaged sample says nothing about motion
    return raw


def _take(raw: _Raw, key: keyspace.ParsedKey, payload: bytes) -> None:
    if key.area == "ego" and key.channel == "pose":
        p = m.POSE.decode(payload)
        raw.samples[key.node_id].append(np.array([[p.t, p.x, p.y, p.yaw, p.vx, p.vy]]))
        raw.humans.add(key.node_id)
    elif key.area == "world" and key.channel == "npc":
        _take_batch(raw, m.NPC_BATCH.decode(payload))
    elif key.area == "world" and key.channel == "events":
        event = m.WORLD_EVENT.decode(payload)
        raw.events.append(event)
        if isinstance(event, m.Spawned) and event.actor_kind:
            raw.kinds[event.node_id] = event.actor_kind
    elif key.area == "authority" and key.channel == "map" and raw.road_map is None:
        raw.road_map = m.MAP.decode(payload)
    elif key.area == "authority" and key.channel == "snapshot":
        for ego in m.SNAPSHOT.decode(payload).egos:
            raw.kinds[ego.node_id] = ego.actor_kind or raw.kinds.get(ego.node_id, "other")
            raw.extents[ego.node_id] = ego.extent


def _take_batch(raw: _Raw, batch: m.NpcBatch) -> None:
    rows = batch.array()
    table = np.column_stack(
        [np.full(len(rows), batch.t), *(rows[f].astype(np.float64) for f in
                                        ("x", "y", "yaw", "vx", "vy"))]
    )  # fmt: skip
    for npc_id, row, source in zip(batch.ids, table, rows, strict=True):
        raw.samples[npc_id].append(row[None, :])
        if npc_id not in raw.extents and source["length"] > 0 and source["width"] > 0:
            raw.extents[npc_id] = m.Extent(float(source["length"]), float(source["width"]))
            raw.kinds[npc_id] = m.ACTOR_KINDS[min(int(source["kind"]), len(m.ACTOR_KINDS) - 1)]


def _sorted_rows(chunks: list[np.ndarray]) -> np.ndarray:
    rows = np.concatenate(chunks)
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    keep = np.concatenate([[True], np.diff(rows[:, 0]) > 0])  # one sample per instant
    return rows[keep]


def _resample(rows: np.ndarray, t: np.ndarray, max_gap_s: float) -> np.ndarray:
    """(5, T): x, y, yaw, vx, vy at grid times, NaN outside the samples and across gaps."""
    times = rows[:, 0]
    out = np.full((5, len(t)), np.nan)
    inside = (t >= times[0]) & (t <= times[-1])
    after = np.clip(np.searchsorted(times, t, side="left"), 1, max(1, len(times) - 1))
    if len(times) > 1:
        inside &= (times[after] - times[after - 1]) <= max_gap_s
    else:
        inside &= np.isclose(t, times[0])
    values = rows[:, 1:].copy()
    values[:, 2] = np.unwrap(values[:, 2])  # heading is interpolated the short way round
    for c in range(5):
        out[c, inside] = np.interp(t[inside], times, values[:, c])
    out[2] = np.angle(np.exp(1j * out[2]))  # back into (-pi, pi]
    return out


def _actor(actor_id: str, raw: _Raw) -> Actor:
    kind = raw.kinds.get(actor_id, "other")
    extent = raw.extents.get(actor_id) or m.KIND_EXTENTS.get(kind) or m.KIND_EXTENTS["other"]
    return Actor(actor_id, kind, actor_id in raw.humans, extent.length, extent.width)
