"""The authority's audio: every `audio.rate_hz`, what each joined human can hear.

Called from the domain's tick (never from a Zenoh callback); the scenes go out through the
outbox on `audio/<node id>`, best effort: a scene that cannot go out now is superseded by the
next one 50 ms later, so nothing waits for a slow link. Listeners are the embodied egos at the
tick time; a node without a pose (an observer) has no place to hear from, and a node nothing
takes audio for (no audio process, no recorder) gets no scene built. With many
listeners, each tick builds the scenes of one phase group (sound_schedule), so no tick
carries them all.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from carlaverse.authority.actors import EgoColumns, EgoNow
from carlaverse.authority.domain import Outbox
from carlaverse.authority.scratch import Scratch
from carlaverse.authority.sound_areas import ListenerAreas
from carlaverse.authority.sound_audibility import audible
from carlaverse.authority.sound_schedule import PhaseGroups
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
        self._groups = PhaseGroups(spec.rate_hz)
        self._scratch = Scratch()
        self.stats = SoundStats()

    @property
    def phase_groups(self) -> int:
        """How many groups the listeners are dealt into (one group's scenes per tick)."""
        return self._groups.groups

    def tick(
        self,
        t: float,
        egos: Sequence[EgoNow],
        frame: NpcFrame,
        weather: Weather | None,
        out: Outbox,
    ) -> None:
        """Publish the scenes due at session time `t` [s] (one phase group's at most)."""
        if not self._spec.enabled or not egos:
            return
        listeners = EgoColumns.of(egos)
        due = self._groups.due(t, listeners.ids)
        if len(due):
            # Only listeners something takes audio for: most participants of a large session
            # render none, and their scenes were most of the authority's audio work.
            ids = listeners.ids
            due = due[np.fromiter((out.hears(ids[i]) for i in due.tolist()), bool, len(due))]
        if not len(due):
            return
        for scene in self.scenes(t, listeners, frame, weather, out.next_seq, due):
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
        only: np.ndarray | None = None,
    ) -> list[AudioScene]:
        """One scene per ego (per ego at the indices `only`, if given): what it hears at `t`,
        loudest first, at most `max_emitters`."""
        spec = self._spec
        wetness = weather.wetness if weather is not None else 0.0
        # Egos come first among the actors, so an ego's index is its sources' owner index.
        listeners = EgoColumns.of(egos)
        chosen = np.arange(len(listeners)) if only is None else only
        on_actors = self._actors.sources(t, actor_columns(listeners, frame), wetness)
        ears = np.stack([listeners.x, listeners.y, listeners.z], axis=1).reshape(-1, 3)[chosen]
        around = self._areas.sources(ears, weather, spec.threshold_db)
        heard = audible(
            ears, on_actors, around, spec.threshold_db, spec.max_emitters, chosen, self._scratch
        )
        ids = [listeners.ids[i] for i in chosen.tolist()]
        return [
            AudioScene(next_seq() if next_seq else 0, t, node_id, emitters)
            for node_id, emitters in zip(ids, heard.emitters_by_listener(), strict=True)
        ]
