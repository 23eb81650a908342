"""The session on Lab Streaming Layer: a marker stream and a session-clock stream.

Whatever records LSL beside a study (LabRecorder into XDF, this project's `lsl_record`) gets:

- `carlaverse-<session>-markers` (or `<stream_prefix>-markers`; type `Markers`, one string
  channel, irregular rate): one marker per trial start and end, trigger firing, notice and
  contact start and end. Each is a JSON object, `{"type": "trigger", "t": <session time
  [s]>, ...the event's fields}`, stamped with the LSL time *at which it happened* (its
  session time `t` moved to this host's `local_clock()`), not when it arrived here.
- `carlaverse-<session>-clock` (type `SessionClock`, one double channel, irregular rate):
  every `clock_period_s` the session time [s] at the sample's LSL timestamp, so an XDF reader
  maps any stream's LSL time to session time by interpolating between these pairs.

Events come from `world/events` over Zenoh. The callback only queues the payload (bounded,
a full queue drops and counts); a worker thread decodes, stamps and pushes. Markers wait for
the first clock sync (before it no LSL time can be given to a session time).
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import msgspec
import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.recording.encoding import to_view
from carlaverse.study.lsl_clock import SessionTimeFollower

log = logging.getLogger(__name__)

MARKER_TYPE = "Markers"  # the XDF content type LabRecorder and analysis tools expect
CLOCK_TYPE = "SessionClock"
# World events that become markers; spawns and despawns do not (the recording has them).
MARKED_EVENTS = (m.TriggerFired, m.Notice, m.ContactStarted, m.ContactEnded)
# A queued item: (session time [s] or None for "now", the marker's fields or None for an
# event, the event's payload)
_Item = tuple[float | None, dict[str, Any] | None, bytes]
DEFAULT_QUEUE_SIZE = 4096  # events waiting for the worker (or the first clock sync)


def marker_stream_name(session: str) -> str:
    """The marker stream's name when no `stream_prefix` is given."""
    return f"carlaverse-{session}-markers"


def clock_stream_name(session: str) -> str:
    return f"carlaverse-{session}-clock"


@dataclass(slots=True)
class MarkerStats:
    published: int = 0  # markers pushed to the outlet
    ignored: int = 0  # world events that are no marker (spawns, despawns)
    bad: int = 0  # payloads on world/events that are no world event
    dropped: int = 0  # events lost to a full queue
    failed: int = 0  # markers the outlet refused (logged)
    clock_samples: int = 0


class SessionMarkers:
    """Publishes a session's markers and clock on LSL (`start`, then `close`)."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        pylsl: Any,
        follower: SessionTimeFollower,
        *,
        clock_period_s: float = 1.0,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        stream_prefix: str = "",
    ) -> None:
        self._session = session
        self._keys = keys
        self._pylsl = pylsl
        self._follower = follower
        self._clock_period_s = clock_period_s
        # One name across a study's trials (each its own session) lets LabRecorder follow the
        # outlet from trial to trial by its source id instead of asking for a new stream.
        self._prefix = stream_prefix or f"carlaverse-{keys.session}"
        # (session time [s] or None for "now", the marker's fields or None, an event payload)
        self._queue: queue.Queue[_Item] = queue.Queue(queue_size)
        self._json = msgspec.json.Encoder()
        self.stats = MarkerStats()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lsl-markers", daemon=True)
        self._subscriber: Any = None
        self._markers: Any = None
        self._clock: Any = None

    def start(self) -> SessionMarkers:
        self._markers = self._outlet(f"{self._prefix}-markers", MARKER_TYPE, "string")
        self._clock = self._outlet(f"{self._prefix}-clock", CLOCK_TYPE, "double64")
        self._subscriber = self._session.declare_subscriber(
            self._keys.world("events"), self._on_event
        )
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop listening, push what is queued (if the clock is synced), drop the outlets."""
        if self._subscriber is not None:
            self._subscriber.undeclare()
            self._subscriber = None
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        self._markers = self._clock = None  # liblsl closes an outlet when it is collected

    # ------------------------------------------------------------------ what is marked

    def trial_started(
        self, trial: str, session_t: float | None = None, **fields: str | float
    ) -> None:
        """Mark a trial's start at session time `session_t` [s] (None: now)."""
        self.mark("trial_start", {"trial": trial, **fields}, session_t)

    def trial_ended(
        self, trial: str, session_t: float | None = None, **fields: str | float
    ) -> None:
        self.mark("trial_end", {"trial": trial, **fields}, session_t)

    def mark(
        self,
        kind: str,
        fields: Mapping[str, str | float] | None = None,
        session_t: float | None = None,
    ) -> None:
        """A marker `{"type": kind, "t": ..., **fields}` at session time `session_t` [s]
        (None: when the worker stamps it, within milliseconds)."""
        self._offer((session_t, {"type": kind, **(fields or {})}, b""))

    def _on_event(self, sample: zenoh.Sample) -> None:
        """Zenoh thread: queue the payload, nothing else."""
        self._offer((None, None, sample.payload.to_bytes()))

    def _offer(self, item: _Item) -> None:
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.stats.dropped += 1

    # ------------------------------------------------------------------ worker

    def _run(self) -> None:
        while not self._stop.is_set() and not self._follower.wait_synced(0.1):
            pass  # no session time yet: markers wait in the queue
        next_clock = 0.0
        while self._follower.synced:
            now = self._follower.clock.local.now()
            if now >= next_clock:
                self._push_clock(now)
                next_clock = now + self._clock_period_s
            try:
                item = self._queue.get(timeout=min(0.05, max(0.0, next_clock - now)))
            except queue.Empty:
                if self._stop.is_set():
                    return
                continue
            try:
                self._push_marker(*item)
            except Exception as exc:  # one marker that cannot go must not end the others
                self.stats.failed += 1
                log.warning("LSL marker not published: %s: %s", type(exc).__name__, exc)

    def _push_clock(self, local_t: float) -> None:
        self._clock.push_sample([self._follower.to_session(local_t)], local_t)
        self.stats.clock_samples += 1

    def _push_marker(
        self, session_t: float | None, fields: dict[str, Any] | None, payload: bytes
    ) -> None:
        if fields is None:
            fields = self._event_marker(payload)
            if fields is None:
                return
            session_t = fields["t"]
        if session_t is None:
            local_t = self._follower.clock.local.now()
            session_t = self._follower.to_session(local_t)
        else:
            local_t = self._follower.to_local(session_t)
        fields.setdefault("t", session_t)
        self._markers.push_sample([self._json.encode(fields).decode()], local_t)
        self.stats.published += 1

    def _event_marker(self, payload: bytes) -> dict[str, Any] | None:
        try:
            event = m.WORLD_EVENT.decode(payload)
        except m.MessageError as exc:
            self.stats.bad += 1
            log.debug("not a world event on world/events: %s", exc)
            return None
        if not isinstance(event, MARKED_EVENTS):
            self.stats.ignored += 1
            return None
        return to_view(event)  # {"type": "trigger", "seq": .., "t": .., ...}

    def _outlet(self, name: str, content_type: str, channel_format: str) -> Any:
        pylsl = self._pylsl
        session = self._keys.session
        info = pylsl.StreamInfo(
            name, content_type, 1, pylsl.IRREGULAR_RATE, channel_format, f"carlaverse/{name}"
        )
        desc = info.desc()
        desc.append_child_value("session", session)
        channel = desc.append_child("channels").append_child("channel")
        channel.append_child_value("label", "marker" if channel_format == "string" else "t")
        if channel_format != "string":
            channel.append_child_value("unit", "s")
            channel.append_child_value("type", "session_time")
        return pylsl.StreamOutlet(info)
