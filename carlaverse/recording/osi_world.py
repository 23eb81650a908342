"""One pass over a recording for its OSI export: every actor's samples, kinds, sizes and lights,
the signal states, the weather and the map; and the series read back at any time.

An actor's samples are rows of `COLUMNS` (a pose's fields; an NPC row fills what it has). An
actor's acceleration is what its poses carry; where they carry none (all zero: scripted
nodes, NPCs) it is the derivative of its recorded velocity (`ActorTrack`).
"""

from __future__ import annotations

import bisect
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Generic, TypeVar

import numpy as np

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.recording.osi_lights import ego_bits
from carlaverse.recording.reading import iter_samples

T = TypeVar("T")
# columns of an actor's sample rows
COLUMNS = ("t", "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz",
           "wx", "wy", "wz", "ax", "ay", "az")  # fmt: skip
COLUMN = {name: i for i, name in enumerate(COLUMNS)}
ANGLES = [COLUMN["roll"], COLUMN["pitch"], COLUMN["yaw"]]


@dataclass
class RecordedWorld:
    """What one pass over a recording gives the OSI export."""

    samples: dict[str, list[np.ndarray]] = field(default_factory=lambda: defaultdict(list))
    kinds: dict[str, str] = field(default_factory=dict)
    extents: dict[str, m.Extent] = field(default_factory=dict)
    humans: set[str] = field(default_factory=set)
    lights: list[tuple[float, dict[str, str]]] = field(default_factory=list)  # (t, id -> state)
    weather: list[tuple[float, m.Weather]] = field(default_factory=list)
    # actor -> (t, messages.LIGHT_* bits) where they changed: NPC rows, an ego's EgoState
    vehicle_lights: dict[str, list[tuple[float, int]]] = field(
        default_factory=lambda: defaultdict(list)
    )
    road_map: m.MapReply | None = None
    skipped: int = 0  # samples of our keys that did not decode

    def actor_ids(self) -> list[str]:
        """Egos first, then NPCs, each sorted (the analysis's order)."""
        return sorted((a for a, rows in self.samples.items() if rows),
                      key=lambda a: (a not in self.humans, a))  # fmt: skip

    def kind(self, actor_id: str) -> str:
        kind = self.kinds.get(actor_id, "other")
        return kind if kind in m.ACTOR_KINDS else "other"

    def extent(self, actor_id: str) -> m.Extent:
        return self.extents.get(actor_id) or m.KIND_EXTENTS[self.kind(actor_id)]


def read_world(path: str | Path) -> RecordedWorld:
    """Actors' samples, kinds, extents, signal states and the map of a recording, in one pass."""
    world = RecordedWorld()
    for sample in iter_samples(path):
        if sample.kind != "put":
            continue
        try:
            _take(world, keyspace.parse(sample.key), sample.payload)
        except (keyspace.KeySpaceError, m.MessageError):
            world.skipped += 1  # a foreign or damaged sample says nothing about the world
    return world


def _take(world: RecordedWorld, key: keyspace.ParsedKey, payload: bytes) -> None:
    if key.area == "ego" and key.channel == "pose":
        p = m.POSE.decode(payload)
        world.samples[key.node_id].append(np.array([[p.t, p.x, p.y, p.z, p.roll, p.pitch, p.yaw,
            p.vx, p.vy, p.vz, p.wx, p.wy, p.wz, p.ax, p.ay, p.az]]))  # fmt: skip
        world.humans.add(key.node_id)
    elif key.area == "ego" and key.channel == "state":
        ego_state = m.EGO_STATE.decode(payload)
        world.vehicle_lights[key.node_id].append((ego_state.t, ego_bits(ego_state)))
    elif key.area == "world" and key.channel == "npc":
        _take_batch(world, m.NPC_BATCH.decode(payload))
    elif key.area == "world" and key.channel == "lights":
        state = m.LIGHTS.decode(payload)
        world.lights.append((state.t, {light.id: light.state for light in state.lights}))
    elif key.area == "world" and key.channel == "weather":
        weather = m.WEATHER.decode(payload)
        world.weather.append((weather.t, weather))
    elif key.area == "world" and key.channel == "events":
        event = m.WORLD_EVENT.decode(payload)
        if isinstance(event, m.Spawned) and event.actor_kind:
            world.kinds[event.node_id] = event.actor_kind
    elif key.area == "authority" and key.channel == "map" and world.road_map is None:
        world.road_map = m.MAP.decode(payload)
    elif key.area == "authority" and key.channel == "snapshot":
        for ego in m.SNAPSHOT.decode(payload).egos:
            world.kinds[ego.node_id] = ego.actor_kind or world.kinds.get(ego.node_id, "other")
            world.extents[ego.node_id] = ego.extent


def _take_batch(world: RecordedWorld, batch: m.NpcBatch) -> None:
    rows = batch.array()
    table = np.zeros((len(rows), len(COLUMNS)))
    table[:, COLUMN["t"]] = batch.t
    for name in ("x", "y", "z", "yaw", "vx", "vy"):
        table[:, COLUMN[name]] = rows[name]
    table[:, COLUMN["wz"]] = rows["yaw_rate"]
    for npc_id, row, source in zip(batch.ids, table, rows, strict=True):
        world.samples[npc_id].append(row[None, :])
        seen = world.vehicle_lights[npc_id]
        if not seen or seen[-1][1] != int(source["lights"]):
            seen.append((batch.t, int(source["lights"])))
        if npc_id not in world.extents and source["length"] > 0 and source["width"] > 0:
            size = (float(source["length"]), float(source["width"]), float(source["height"]))
            world.extents[npc_id] = m.Extent(*size) if size[2] > 0 else m.Extent(*size[:2])
            world.kinds[npc_id] = m.ACTOR_KINDS[min(int(source["kind"]), len(m.ACTOR_KINDS) - 1)]


class ActorTrack:
    """One actor's samples, sorted, with accelerations filled in where none were carried."""

    def __init__(self, chunks: list[np.ndarray], max_gap_s: float) -> None:
        rows = np.concatenate(chunks)
        rows = rows[np.argsort(rows[:, 0], kind="stable")]
        rows = rows[np.concatenate([[True], np.diff(rows[:, 0]) > 0])]  # one per instant
        rows[:, ANGLES] = np.unwrap(rows[:, ANGLES], axis=0)  # interpolate the short way
        self.max_gap_s = max_gap_s
        self.t = rows[:, 0]
        if not rows[:, COLUMN["ax"] :].any():  # no acceleration carried: differentiate velocity
            rows[:, COLUMN["ax"] :] = self._derivative(rows[:, COLUMN["vx"] : COLUMN["vz"] + 1])
        self.rows = rows

    def _derivative(self, values: np.ndarray) -> np.ndarray:
        """d values / dt within each stretch without a gap (0 for a lone sample)."""
        out = np.zeros_like(values)
        cuts = np.flatnonzero(np.diff(self.t) > self.max_gap_s) + 1
        for piece in np.split(np.arange(len(self.t)), cuts):
            if len(piece) > 1:
                out[piece] = np.gradient(values[piece], self.t[piece], axis=0)
        return out

    def at(self, t: float) -> np.ndarray | None:
        """The row interpolated at session time `t`, or None where the actor is absent."""
        if t < self.t[0] or t > self.t[-1]:
            return None
        after = min(max(1, bisect.bisect_left(self.t, t)), len(self.t) - 1)
        if len(self.t) == 1:
            return self.rows[0] if math.isclose(t, self.t[0]) else None
        t0, t1 = self.t[after - 1], self.t[after]
        if t1 - t0 > self.max_gap_s:
            return None
        w = (t - t0) / (t1 - t0)
        return self.rows[after - 1] * (1 - w) + self.rows[after] * w


class Latest(Generic[T]):
    """What a series of changes says at time t: its newest value at or before t."""

    def __init__(self, changes: list[tuple[float, T]]) -> None:
        ordered = sorted(changes, key=lambda change: change[0])  # stable: receive order kept
        self.times = [t for t, _ in ordered]
        self.values = [value for _, value in ordered]

    def at(self, t: float) -> T | None:
        k = bisect.bisect_right(self.times, t) - 1
        return self.values[k] if k >= 0 else None
