"""A trial that ends on an event of its world rather than at its duration.

`trial.end_on_triggers` names scenario triggers whose firing ends the trial, and
`trial.end_on_contact` ends it at the first contact between two actors; `duration_s` stays the
limit either way. The authority's `world/events` (messages.WorldEvent) are heard in the
Zenoh callback, which only decodes and sets a flag; the trial's loop looks at it.
"""

from __future__ import annotations

import logging
import threading

from carlaverse import messages as m

log = logging.getLogger(__name__)


class EndCondition:
    """Whether the trial's world has said it is over; `on_event` is fed each payload."""

    def __init__(self, triggers: list[str], contact: bool) -> None:
        self.triggers = set(triggers)
        self.contact = contact
        self.reason = ""
        self.met = threading.Event()
        self.dropped = 0  # payloads that were no world event

    @property
    def wanted(self) -> bool:
        return bool(self.triggers) or self.contact

    def on_event(self, payload: bytes) -> None:
        try:
            event = m.WORLD_EVENT.decode(payload)
        except m.MessageError as exc:
            self.dropped += 1
            log.debug("world event dropped: %s", exc)
            return
        if self.met.is_set():
            return
        if isinstance(event, m.TriggerFired) and event.trigger_id in self.triggers:
            self.reason = f"trigger {event.trigger_id} fired at session time {event.t:.3f} s"
        elif isinstance(event, m.ContactStarted) and self.contact:
            self.reason = f"contact of {event.a} and {event.b} at session time {event.t:.3f} s"
        else:
            return
        self.met.set()
