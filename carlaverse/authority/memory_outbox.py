"""An outbox that keeps what a domain sends, encoded as it would go on the wire.

For tests, benchmarks and offline runs of a domain: every message is encoded with its codec
(so encoding cost and failures are real) and kept, decoded objects beside their bytes.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

from carlaverse import messages as m


@dataclass(slots=True)
class MemoryOutbox:
    """Collects a domain's output per channel; `keep=False` only encodes and counts."""

    keep: bool = True
    deaf: set[str] = field(default_factory=set)  # listeners nothing takes audio for
    npcs: list[m.NpcBatch] = field(default_factory=list)
    lights_states: list[m.LightsState] = field(default_factory=list)
    weathers: list[m.Weather] = field(default_factory=list)
    events: list[m.WorldEvent] = field(default_factory=list)
    impulses: list[tuple[str, m.Impulse]] = field(default_factory=list)
    audio_scenes: list[tuple[str, m.AudioScene]] = field(default_factory=list)
    bytes_sent: int = 0
    _seq: itertools.count = field(default_factory=lambda: itertools.count(1))

    def next_seq(self) -> int:
        return next(self._seq)

    def npc(self, batch: m.NpcBatch) -> None:
        self._sent(m.NPC_BATCH.encode(batch), self.npcs, batch)

    def lights(self, state: m.LightsState) -> None:
        self._sent(m.LIGHTS.encode(state), self.lights_states, state)

    def weather(self, state: m.Weather) -> None:
        self._sent(m.WEATHER.encode(state), self.weathers, state)

    def event(self, event: m.WorldEvent) -> None:
        self._sent(m.WORLD_EVENT.encode(event), self.events, event)

    def impulse(self, node_id: str, impulse: m.Impulse) -> None:
        self._sent(m.IMPULSE.encode(impulse), self.impulses, (node_id, impulse))

    def audio(self, node_id: str, scene: m.AudioScene) -> None:
        self._sent(m.AUDIO_SCENE.encode(scene), self.audio_scenes, (node_id, scene))

    def hears(self, node_id: str) -> bool:
        return node_id not in self.deaf

    def _sent(self, payload: bytes, into: list, item: object) -> None:
        self.bytes_sent += len(payload)
        if self.keep:
            into.append(item)
