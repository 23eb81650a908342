"""The authority's audio: every `audio.rate_hz`, what each joined human can hear.

Called from the domain's tick (never from a Zenoh callback); the scenes go out through the
outbox on `audio/<node id>`, best effort: a scene that cannot go out now is superseded by the
next one 50 ms later, so nothing waits for a slow link. Listeners are the embodied egos at the
tick time; a node without a pose (an observer) has no place to hear from.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.authority.actors import EgoColumns, EgoNow
from carlaverse.authority.domain import Outbox
from carlaverse.authority.scratch import Scratch
from carlaverse.authority.sound_areas import ListenerAreas
from carlaverse.authority.sound_audibility import audible
from carlaverse.authority.sound_sources import ActorSounds, actor_columns
from carlaverse.messages import AudioScene, MapArea, Weather
from carlaverse.traffic.engine import NpcFrame
from carlaverse.traffic.soundscape import AudioSpec


@dataclass(slots=True)
class SoundStats:
    scenes: int = 0  # sent, all listeners together
    emitters: int = 0  # in those scenes


class SoundPublisher:
    """Decides when audio goes out and builds one scene per listener."""

    def __init__(self, spec: AudioSpec, areas: Sequence[MapArea]) -> None:
        self._spec = spec
        self._actors = ActorSounds(spec.sirens)
        self._areas = ListenerAreas(areas if spec.map_ambience else [], spec.construction)
        self._next_t = -math.inf
        self._scratch = Scratch()
        self.stats = SoundStats()

    def tick(
        self,
        t: float,
        egos: Sequence[EgoNow],
        frame: NpcFrame,
        weather: Weather | None,
        out: Outbox,
    ) -> None:
        """Publish the scenes due at session time `t` [s]."""
        if not self._spec.enabled or not egos or t < self._next_t:
            return
        period = 1.0 / self._spec.rate_hz
        self._next_t = max(self._next_t + period, t + period / 2)
        for scene in self.scenes(t, egos, frame, weather, out.next_seq):
            out.audio(scene.listener, scene)
            self.stats.scenes += 1
            self.stats.emitters += len(scene.emitters)

    def scenes(
        self,
        t: float,
        egos: Sequence[EgoNow],
        frame: NpcFrame,
        weather: Weather | None,
        next_seq: Callable[[], int] | None = None,
    ) -> list[AudioScene]:
        """One scene per ego: what it hears at `t`, loudest first, at most `max_emitters`."""
        spec = self._spec
        wetness = weather.wetness if weather is not None else 0.0
        # Egos come first among the actors, so an ego's index is its sources' owner index.
        listeners = EgoColumns.of(egos)
        on_actors = self._actors.sources(t, actor_columns(listeners, frame), wetness)
        ears = np.stack([listeners.x, listeners.y, listeners.z], axis=1).reshape(-1, 3)
        around = self._areas.sources(ears, weather, spec.threshold_db)
        heard = audible(
            ears, on_actors, around, spec.threshold_db, spec.max_emitters, scratch=self._scratch
        )
        chosen = heard.emitters_by_listener()
        return [
            AudioScene(next_seq() if next_seq else 0, t, node_id, emitters)
            for node_id, emitters in zip(listeners.ids, chosen, strict=True)
        ]
