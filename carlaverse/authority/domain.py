"""The seam between the authority's membership core and its global domain (docs/architecture.md §6).

The membership core (`carlaverse.authority.service`) owns presence, joins, the clock and
despawns. Everything else global — traffic, lights, weather, collisions, the map — is a
`GlobalDomain` it ticks. The core hands the domain the current egos and an `Outbox`; the
domain never touches Zenoh itself, so it can be tested without a network.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

from carlaverse.messages import (
    AudioScene,
    EgoInfo,
    Impulse,
    LightsState,
    MapReply,
    NpcBatch,
    Pose,
    ScenarioReply,
    SpawnPoint,
    Weather,
    WorldEvent,
)


@dataclass(slots=True)
class EgoTrack:
    """What the authority knows of one joined ego."""

    info: EgoInfo
    instance: str
    joined_t: float  # [s] session time of the join
    last_pose: Pose | None = None
    last_rx_t: float = -1.0  # [s] session time the last pose arrived
    config_yaml: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def node_id(self) -> str:
        return self.info.node_id


class Outbox(Protocol):
    """Where a domain sends what it decides; the core turns it into Zenoh puts."""

    def npc(self, batch: NpcBatch) -> None: ...
    def lights(self, state: LightsState) -> None: ...
    def weather(self, state: Weather) -> None: ...
    def event(self, event: WorldEvent) -> None: ...
    def impulse(self, node_id: str, impulse: Impulse) -> None: ...
    def audio(self, node_id: str, scene: AudioScene) -> None: ...
    def hears(self, node_id: str) -> bool:
        """Whether anything takes `node_id`'s audio scenes (else building them is waste)."""
        ...

    def next_seq(self) -> int: ...


class GlobalDomain(Protocol):
    """Traffic, lights, weather and collisions, ticked by the authority at a fixed rate."""

    def ego_joined(self, track: EgoTrack) -> None: ...
    def ego_left(self, node_id: str) -> None: ...
    def tick(self, t: float, egos: Mapping[str, EgoTrack], out: Outbox) -> None: ...
    def snapshot_parts(self) -> tuple[NpcBatch | None, LightsState | None, Weather | None]: ...
    def map_reply(self) -> MapReply | None: ...
    def scenario_reply(self) -> ScenarioReply | None: ...
    def spawn_point(self, node_kind: str, node_id: str) -> SpawnPoint | None: ...
    def close(self) -> None: ...


# Without a scenario, each embodied node starts in a row of its own, side by side along y,
# all heading east (+x): first at the origin, as before, the next 8 m to its right, and so on.
# With one start for all, two participants stood on one spot, in contact from their first pose.
ROW_GAP_M = 8.0


class EmptyDomain:
    """A world with nothing global in it: membership only (tests, minimal sessions)."""

    def __init__(self) -> None:
        self._rows: dict[str, int] = {}  # node id -> its row, kept for a re-join
        self._lock = threading.Lock()  # joins are answered on Zenoh's threads

    def ego_joined(self, track: EgoTrack) -> None:
        pass

    def ego_left(self, node_id: str) -> None:
        pass

    def tick(self, t: float, egos: Mapping[str, EgoTrack], out: Outbox) -> None:
        pass

    def snapshot_parts(self) -> tuple[NpcBatch | None, LightsState | None, Weather | None]:
        return None, None, None

    def map_reply(self) -> MapReply | None:
        return None

    def scenario_reply(self) -> ScenarioReply | None:
        return None

    def spawn_point(self, node_kind: str, node_id: str) -> SpawnPoint | None:
        if node_kind == "observer":
            return None  # nothing to place
        with self._lock:
            row = self._rows.setdefault(node_id, len(self._rows))
        return SpawnPoint(0.0, -ROW_GAP_M * row if row else 0.0, 0.0, 0.0)  # never -0.0

    def close(self) -> None:
        pass
