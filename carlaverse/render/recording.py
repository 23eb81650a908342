"""A world view fed from an MCAP recording, so any moment of a session can be rendered.

`RecordedWorld` is the recording's `WorldSource`: its samples go into a real `WorldView`
through the view's intake (`world.source.SampleFeed`: each decoded once, in the intake's one
representation, as a live node's would be), in receive order; the receive time is the
recorder's log time moved onto the session clock (by the offset of the first pose: log time −
the pose's own session time). `advance(t)` feeds everything received up to session time `t`;
the view then decides what it shows at `t`, as it would have live (walkers' skeletons
included). Extents and NPC lamps, which the view does not keep, come from the recorded
snapshot and NPC batches, as decoded for the view.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

from carlaverse import messages as m
from carlaverse.recording.reading import RecordedSample, iter_samples
from carlaverse.recording.timeline import receive_offset_ns
from carlaverse.render.frame import (
    SceneFrame,
    frame_from_view,
    npc_attributes,
    skeleton_angles,
    with_skeletons,
)
from carlaverse.world.intake import WorldIntake
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.source import SampleFeed
from carlaverse.world.world_view import WorldView

log = logging.getLogger(__name__)
VIEW_ID = "carlaverse-render"  # never a node id of the session: ids are reserved per node


class RecordedWorld:
    """Replays a recording into a WorldView, forward only."""

    def __init__(self, path: str | Path, settings: InterpolationSettings | None = None) -> None:
        self.view = WorldView(VIEW_ID, settings or InterpolationSettings())
        self._feed = SampleFeed(self.view.intake)
        self.kinds: dict[str, str] = {}
        self.extents: dict[str, m.Extent] = {}
        self.npc_lights: dict[str, int] = {}
        self._samples: Iterator[RecordedSample] = iter_samples(path)
        self._next: RecordedSample | None = next(self._samples, None)
        self._offset_s = receive_offset_ns(path) / 1e9  # [s] log time minus session time

    @property
    def intake(self) -> WorldIntake:
        return self.view.intake

    @property
    def bad_samples(self) -> int:
        """Recorded samples that could not be read (a key outside the key space, a payload
        that does not decode) and were skipped, the poses the view refused among them."""
        return sum(self.view.dropped.snapshot().values())

    def feed(self, until_t: float) -> None:
        """Hand the view every sample received up to session time `until_t` [s]."""
        while self._next is not None and self._session_rx(self._next) <= until_t:
            sample = self._next
            message = self._feed.route(
                sample.key, sample.kind, sample.payload, self._session_rx(sample)
            )
            self._note(message)
            self._next = next(self._samples, None)

    def advance(self, t: float) -> None:
        """Feed every sample received up to session time `t` [s], then update the view."""
        self.feed(t)
        self.view.update(t)

    def frame(self, t: float) -> SceneFrame:
        self.advance(t)
        frame = frame_from_view(
            self.view, t, kinds=self.kinds, extents=self.extents, npc_lights=self.npc_lights
        )
        return with_skeletons(frame, skeleton_angles(self.view))

    def _session_rx(self, sample: RecordedSample) -> float:
        return sample.log_time_ns / 1e9 - self._offset_s

    def _note(self, message: object) -> None:
        """Keep what the view does not: egos' kinds and extents, NPCs' extents and lamps."""
        if isinstance(message, m.Snapshot):
            for ego in message.egos:
                self.kinds[ego.node_id] = ego.actor_kind
                self.extents[ego.node_id] = ego.extent
        elif isinstance(message, m.NpcBatch):
            extents, lamps = npc_attributes(message)
            self.extents.update(extents)
            self.npc_lights = lamps
