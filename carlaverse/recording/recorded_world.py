"""One pass over a recording: every road user's samples, kinds and sizes, the vehicle lights,
the signal states, the weather, the world events and the map.

Both readers of a finished recording start here: the OSI export (`recording/osi_world.py`)
and the analysis (`analysis/tracks.py`), so a recording means the same to both. Humans come
from their pose telemetry (`ego/<id>/pose`), NPCs from the authority's batches (`world/npc`).
An actor's samples are rows of `COLUMNS` (a pose's fields; an NPC row fills what it has and
leaves the rest 0).
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

Progress = Callable[[int], None]  # called with the number of samples read so far
PROGRESS_EVERY = 10000  # [samples] between two progress calls
# columns of an actor's sample rows
COLUMNS = ("t", "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz",
           "wx", "wy", "wz", "ax", "ay", "az")  # fmt: skip
COLUMN = {name: i for i, name in enumerate(COLUMNS)}
_BLINKERS = {"off": 0, "left": m.LIGHT_LEFT_BLINKER, "right": m.LIGHT_RIGHT_BLINKER,
             "hazard": m.LIGHT_LEFT_BLINKER | m.LIGHT_RIGHT_BLINKER}  # fmt: skip


@dataclass
class RecordedWorld:
    """What one pass over a recording gives its readers."""

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
    events: list[m.WorldEvent] = field(default_factory=list)  # `world/events`, recorded order
    road_map: m.MapReply | None = None  # the first map reply kept, if any
    read: int = 0  # samples read
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

    def rows(self, actor_id: str) -> np.ndarray:
        """The actor's samples sorted by time, one per instant (the first received kept)."""
        rows = np.concatenate(self.samples[actor_id])
        rows = rows[np.argsort(rows[:, COLUMN["t"]], kind="stable")]
        return rows[np.concatenate([[True], np.diff(rows[:, COLUMN["t"]]) > 0])]


def ego_bits(state: m.EgoState) -> int:
    """The light bits of an ego's state, its indicator folded into the blinker bits, so an
    ego's lights read as an NPC row's do (both blinkers at once: the hazard warning)."""
    blinkers = m.LIGHT_LEFT_BLINKER | m.LIGHT_RIGHT_BLINKER
    return (state.lights & ~blinkers) | _BLINKERS.get(state.indicator, 0)


def read_world(path: str | Path, progress: Progress | None = None) -> RecordedWorld:
    """Everything its readers take from a recording, in one pass (recordings run to GBs)."""
    world = RecordedWorld()
    for sample in iter_samples(path):
        world.read += 1
        if progress and world.read % PROGRESS_EVERY == 0:
            progress(world.read)
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
        world.events.append(event)
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
