"""`carlaverse record --lsl NAME`: Lab Streaming Layer streams into the recording.

The flags, and the glue between the recorder and `carlaverse.study.lsl_record`: streams are
found before the session is opened (a missing one fails at once, naming it, with nothing
written), then recorded into the same MCAP as the session's keys, on `lsl/<name>`.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

import zenoh

from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.study.lsl_api import LslClock, LslConfigConflict, LslNetwork, LslUnavailable, load
from carlaverse.study.lsl_clock import SessionTimeFollower
from carlaverse.study.lsl_markers import SessionMarkers
from carlaverse.study.lsl_record import LslRecording, StreamMissing, resolve
from carlaverse.study.lsl_sink import SharedSink

# What --lsl can fail with before anything starts: a usage error (exit 2), naming the fix.
LSL_ERRORS = (LslUnavailable, LslConfigConflict, StreamMissing)
DEFAULT_WAIT_S = 10.0  # [s] an LSL app started with the recorder announces itself in ~1 s


def add_lsl_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Lab Streaming Layer (needs pip install 'carlaverse[study]')")
    group.add_argument(
        "--lsl",
        action="append",
        default=[],
        metavar="NAME",
        help="record the LSL stream NAME (or NAME@HOST) on channel lsl/NAME, with each "
        "sample's session time; repeatable",
    )
    group.add_argument(
        "--lsl-markers",
        action="store_true",
        help="publish the session's LSL marker stream (triggers, notices, contacts) and "
        "session-clock stream while recording",
    )
    group.add_argument(
        "--lsl-wait",
        type=float,
        default=DEFAULT_WAIT_S,
        metavar="S",
        help=f"how long to look for the --lsl streams [s] (default {DEFAULT_WAIT_S:g})",
    )
    group.add_argument(
        "--lsl-scope",
        choices=("machine", "lab"),
        default="machine",
        help="where LSL looks for streams: this host only (default) or the lab network",
    )
    group.add_argument(
        "--lsl-session-id",
        default="default",
        metavar="ID",
        help="liblsl's SessionID: only streams of the same id are seen (default 'default')",
    )


@dataclass
class LslPlan:
    """What `--lsl*` asked for, with the streams already found."""

    pylsl: Any
    streams: list[Any]
    markers: bool
    running: list[Any] = field(default_factory=list)
    recording: LslRecording | None = None

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> LslPlan | None:
        """None when no --lsl flag was given; StreamMissing or LslUnavailable otherwise."""
        if not args.lsl and not args.lsl_markers:
            return None
        pylsl = load(LslNetwork(args.lsl_scope, args.lsl_session_id))
        return cls(pylsl, resolve(pylsl, args.lsl, args.lsl_wait), args.lsl_markers)

    def start(self, session: zenoh.Session, keys: Keys, sink: McapSink) -> None:
        if not isinstance(sink, SharedSink):
            raise TypeError("LSL streams need a SharedSink (the recorder and inlets share it)")
        follower = SessionTimeFollower(session, keys, LslClock(self.pylsl)).start()
        self.running.append(follower)
        if self.markers:
            self.running.append(SessionMarkers(session, keys, self.pylsl, follower).start())
        if self.streams:
            self.recording = LslRecording(
                session, keys, sink, self.pylsl, self.streams, follower=follower
            ).start()

    def stop(self) -> str:
        """Stop (before the sink closes); one line saying what was recorded."""
        stats = self.recording.stop() if self.recording else []
        for part in reversed(self.running):
            part.close()
        parts = [
            f"{s.topic} {s.samples} samples"
            + (f" ({s.bad_shape + s.bad_time} bad, dropped)" if s.bad_shape + s.bad_time else "")
            + (f" STOPPED: {s.error}" if s.error else "")
            for s in stats
        ]
        return "LSL: " + (", ".join(parts) or "markers published")
