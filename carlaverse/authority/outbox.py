"""The authority's outbox on Zenoh: one publisher per world channel, right delivery class each.

NPC batches and audio scenes may drop under congestion (the next one supersedes them);
lights, weather, events and impulses must arrive, so they are reliable with congestion control
BLOCK and carry sequence numbers for idempotent receivers (docs/architecture.md §4).

Every put carries a timestamp from the authority's own session: its id is the session's zid,
which the join reply names, so nodes can tell the authority's world messages from anyone
else's (see `carlaverse.transport.inbound` for what that does and does not prove).
"""

from __future__ import annotations

import itertools
from typing import Any

import zenoh

from carlaverse import messages as m
from carlaverse.authority.npc_tiles import NpcTilePublisher
from carlaverse.keys import Keys


class ZenohOutbox:
    def __init__(self, session: zenoh.Session, keys: Keys) -> None:
        self._session = session
        self._keys = keys
        self._seq = itertools.count(1)
        self.sent: dict[str, int] = {}
        self.npc_tile_batches = 0  # batches put on `world/npc/<tile>`
        reliable: dict[str, Any] = {
            "congestion_control": zenoh.CongestionControl.BLOCK,
            "reliability": zenoh.Reliability.RELIABLE,
        }
        self._npc = session.declare_publisher(
            keys.world("npc"), congestion_control=zenoh.CongestionControl.DROP
        )
        self._npc_tiles = NpcTilePublisher(session, keys, session.new_timestamp)
        self._lights = session.declare_publisher(keys.world("lights"), **reliable)
        self._weather = session.declare_publisher(keys.world("weather"), **reliable)
        self._events = session.declare_publisher(
            keys.world("events"), priority=zenoh.Priority.INTERACTIVE_HIGH, **reliable
        )
        # One declared publisher per listener: a put on a declared key skips resolving the
        # key expression, which was most of a scene's cost with hundreds of listeners. Its
        # matching listener keeps `_heard`: the listeners something subscribes to (the node's
        # audio process, a recorder), so no scene is built for a node that renders no audio.
        self._audio: dict[str, tuple[zenoh.Publisher, zenoh.MatchingListener]] = {}
        self._heard: set[str] = set()

    def next_seq(self) -> int:
        return next(self._seq)

    def _count(self, channel: str) -> None:
        self.sent[channel] = self.sent.get(channel, 0) + 1

    def npc(self, batch: m.NpcBatch) -> None:
        self._npc.put(m.NPC_BATCH.encode(batch), timestamp=self._session.new_timestamp())
        self._count("npc")
        self.npc_tile_batches += self._npc_tiles.put(batch)

    def lights(self, state: m.LightsState) -> None:
        self._lights.put(m.LIGHTS.encode(state), timestamp=self._session.new_timestamp())
        self._count("lights")

    def weather(self, state: m.Weather) -> None:
        self._weather.put(m.WEATHER.encode(state), timestamp=self._session.new_timestamp())
        self._count("weather")

    def event(self, event: m.WorldEvent) -> None:
        self._events.put(m.WORLD_EVENT.encode(event), timestamp=self._session.new_timestamp())
        self._count("events")

    def impulse(self, node_id: str, impulse: m.Impulse) -> None:
        self._session.put(
            self._keys.impulse(node_id),
            m.IMPULSE.encode(impulse),
            congestion_control=zenoh.CongestionControl.BLOCK,
            priority=zenoh.Priority.INTERACTIVE_HIGH,
            timestamp=self._session.new_timestamp(),
        )
        self._count("impulse")

    def hears(self, node_id: str) -> bool:
        self._audio_publisher(node_id)  # declared on first ask: its matching status follows
        return node_id in self._heard

    def audio(self, node_id: str, scene: m.AudioScene) -> None:
        publisher = self._audio_publisher(node_id)
        publisher.put(m.AUDIO_SCENE.encode(scene), timestamp=self._session.new_timestamp())
        self._count("audio")

    def _audio_publisher(self, node_id: str) -> zenoh.Publisher:
        declared = self._audio.get(node_id)
        if declared is not None:
            return declared[0]
        # Best effort like NPC batches: the next scene, one audio period later, supersedes it.
        publisher = self._session.declare_publisher(
            self._keys.audio(node_id), congestion_control=zenoh.CongestionControl.DROP
        )
        heard = self._heard

        def on_matching(status: zenoh.MatchingStatus) -> None:
            # A Zenoh thread: a set operation, nothing that waits.
            (heard.add if status.matching else heard.discard)(node_id)

        # Listen first, then read: a subscriber that appears in between is seen either way.
        listener = publisher.declare_matching_listener(on_matching)
        # zenoh 1.10's stub types `matching_status` as bool; it is a MatchingStatus at run time.
        if publisher.matching_status.matching:  # type: ignore[attr-defined]
            heard.add(node_id)
        self._audio[node_id] = (publisher, listener)
        return publisher

    def forget(self, node_id: str) -> None:
        """A node left: drop what was declared for it."""
        declared = self._audio.pop(node_id, None)
        if declared is not None:
            publisher, listener = declared
            listener.undeclare()
            publisher.undeclare()
        self._heard.discard(node_id)
