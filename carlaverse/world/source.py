"""Where a world view's input comes from: its sources, each writing only through its intake.

`WorldSource` is the interface: a source holds the view's `WorldIntake` and `feed(until_t)`
hands it everything received up to a session time. The sources:

    a live session     `transport.inbound.Inbound`, as a node hears it: its Zenoh callbacks hand
                       each sample over as it arrives, once its sender is checked
    a recording        `render.recording.RecordedWorld` (MCAP), `viz.playback`
    a raw observer     `viz.live`: every key of a live session, as a viewer hears it
    a synthetic feed   `testing.render_metrics`: a known path, sampled, each pose written to
                       the intake as it would have travelled

Recordings and the raw observer hand over samples as a key space carries them (key, put or
delete, payload, arrival) through a `SampleFeed`: it decodes each payload once with the
message's one codec and writes it in the intake's one representation (a pose as its 64 bytes;
membership as present, gone with a `Departure`, snapshot). A payload that does not decode is
counted in the intake's `dropped` under its channel (`key` for a key outside the key space)
and skipped.
"""

from __future__ import annotations

from typing import Protocol

from carlaverse import messages as m
from carlaverse.keys import DIGEST_CHANNEL, KeySpaceError, ParsedKey, parse_cached
from carlaverse.world.intake import WorldIntake


class WorldSource(Protocol):
    """Whatever writes a session into a world view, through the view's intake."""

    @property
    def intake(self) -> WorldIntake: ...

    def feed(self, until_t: float) -> None:
        """Hand the intake everything received up to session time `until_t` [s] (a live
        source has handed each sample over as it arrived)."""


class SampleFeed:
    """Samples of a session's key space into a world view's intake, in the order they came.
    Safe from any thread (it keeps nothing but the intake)."""

    def __init__(self, intake: WorldIntake) -> None:
        self.intake = intake

    def route(self, key: str, kind: str, payload: bytes, rx_t: float) -> object | None:
        """Hand one sample to the intake; return the message decoded from it (None for a pose,
        whose bytes the view decodes, for a presence token, or when it was dropped)."""
        try:
            parsed = parse_cached(key)
        except KeySpaceError:
            self.intake.dropped.add("key")
            return None
        return self.route_parsed(parsed, kind, payload, rx_t)

    def route_parsed(self, key: ParsedKey, kind: str, payload: bytes, rx_t: float) -> object | None:
        """`route` for a key already parsed."""
        intake = self.intake
        if key.area == "node":  # a presence token: put when it appears, delete when it goes
            if kind == "delete":
                intake.gone(key.node_id, "liveliness", rx_t)
            else:
                intake.present(key.node_id)
            return None
        if kind != "put" or _repeated(key):
            return None
        if (key.area, key.channel) == ("ego", "pose"):
            intake.pose(key.node_id, payload, rx_t)
            return None
        codec = m.CHANNEL_CODECS.get((key.area, key.channel))
        if codec is None:
            return None
        try:
            message = codec.decode(payload)
        except m.MessageError:
            intake.dropped.add(key.channel or key.area)
            return None
        self.hand(key, message, rx_t)
        return message

    def hand(self, key: ParsedKey, message: object, rx_t: float) -> None:
        """Hand over a message decoded from the sample on `key` (a caller that decoded it for
        its own use too: the viewer's model)."""
        intake = self.intake
        if isinstance(message, m.Skeleton):
            intake.skeleton(key.node_id, message)
        elif isinstance(message, m.EgoState):
            intake.state(key.node_id, message)
        elif isinstance(message, m.NpcBatch):
            intake.npc(message, rx_t)
        elif isinstance(message, m.LightsState):
            intake.lights(message)
        elif isinstance(message, m.Weather):
            intake.weather(message)
        elif isinstance(message, m.Snapshot):
            intake.snapshot(message, rx_t)
        elif isinstance(message, m.Spawned):
            intake.present(message.node_id)
        elif isinstance(message, m.Despawned):
            intake.gone(message.node_id, message.reason, rx_t)
        elif isinstance(message, m.Notice) and message.to in ("", intake.own_id):
            intake.notice(message)


def _repeated(key: ParsedKey) -> bool:
    """Whether the sample repeats what the session's other samples carry: a tile's cut of the
    NPC batch (the whole batch is there too) and the authority's pose digest (each pose is
    there on its own key)."""
    return key.area == "world" and (bool(key.tile) or key.channel == DIGEST_CHANNEL)
