"""Everything LSL that one recorded session runs, behind one door (`record --lsl`, the study
runner's trials):

    lsl = LslSession.prepare(["ECG", "Tobii"], network=LslNetwork(), stream_prefix="carlaverse-s1")
    # per recorded session (a trial), with the recorder's sink a SharedSink:
    lsl.start(session, keys, sink)
    lsl.trial_started("T3", condition="fog")
    ...
    lsl.trial_ended("T3", outcome="completed")
    stats = lsl.stop()            # before the recorder closes the sink

`prepare` loads pylsl and finds the named streams (StreamMissing names the absent ones and
the deadline): done once, before anything starts, so a missing device stops a study before
its first trial rather than at it. `start` follows the session clock on LSL's clock, opens the
marker and session-clock outlets (if `markers`) and records the streams into the sink.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import zenoh

from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.study.lsl_api import LslClock, LslNetwork, load
from carlaverse.study.lsl_clock import SessionTimeFollower
from carlaverse.study.lsl_markers import SessionMarkers
from carlaverse.study.lsl_record import LslRecording, StreamStats, resolve
from carlaverse.study.lsl_sink import SharedSink

DEFAULT_WAIT_S = 10.0  # [s] an LSL app started with the recorder announces itself in ~1 s


class LslSession:
    """The LSL side of recorded sessions: prepared once, started and stopped per session."""

    def __init__(
        self, pylsl: Any, streams: Sequence[Any], *, markers: bool, stream_prefix: str = ""
    ) -> None:
        self.pylsl = pylsl
        self.streams = list(streams)
        self.markers_wanted = markers
        self.stream_prefix = stream_prefix
        self.markers: SessionMarkers | None = None
        self.recording: LslRecording | None = None
        self._follower: SessionTimeFollower | None = None

    @classmethod
    def prepare(
        cls,
        names: Sequence[str],
        *,
        network: LslNetwork | None = None,
        wait_s: float = DEFAULT_WAIT_S,
        markers: bool = True,
        stream_prefix: str = "",
    ) -> LslSession:
        """Load pylsl for `network` and find `names`; LslUnavailable, LslConfigConflict or
        StreamMissing (each one line naming the fix) otherwise."""
        pylsl = load(network)
        streams = resolve(pylsl, names, wait_s) if names else []
        return cls(pylsl, streams, markers=markers, stream_prefix=stream_prefix)

    def start(self, session: zenoh.Session, keys: Keys, sink: McapSink) -> LslSession:
        if self.streams and not isinstance(sink, SharedSink):
            raise TypeError("LSL streams need a SharedSink (the recorder and inlets share it)")
        follower = SessionTimeFollower(session, keys, LslClock(self.pylsl)).start()
        self._follower = follower
        if self.markers_wanted:
            self.markers = SessionMarkers(
                session, keys, self.pylsl, follower, stream_prefix=self.stream_prefix
            ).start()
        if self.streams:
            assert isinstance(sink, SharedSink)
            self.recording = LslRecording(
                session, keys, sink, self.pylsl, self.streams, follower=follower
            ).start()
        return self

    def trial_started(
        self, trial: str, session_t: float | None = None, **fields: str | float
    ) -> None:
        """A `trial_start` marker at session time `session_t` [s] (None: now)."""
        if self.markers is not None:
            self.markers.trial_started(trial, session_t, **fields)

    def trial_ended(
        self, trial: str, session_t: float | None = None, **fields: str | float
    ) -> None:
        if self.markers is not None:
            self.markers.trial_ended(trial, session_t, **fields)

    def stop(self) -> list[StreamStats]:
        """Stop recording (its stats go into the sink as metadata), then the markers (what
        is queued is pushed) and the clock follower. Call before the sink closes."""
        stats = self.recording.stop() if self.recording else []
        if self.markers is not None:
            self.markers.close()
        if self._follower is not None:
            self._follower.close()
        self.recording = self.markers = self._follower = None
        return stats


def describe(stats: Sequence[StreamStats]) -> str:
    """One line: what each stream recorded, and what it dropped or why it stopped."""
    parts = []
    for s in stats:
        bad = s.bad_shape + s.bad_time
        part = f"{s.topic} {s.samples} samples"
        part += f" ({bad} bad, dropped)" if bad else ""
        part += f" STOPPED: {s.error}" if s.error else ""
        parts.append(part)
    return "LSL: " + (", ".join(parts) or "markers published, no stream recorded")
