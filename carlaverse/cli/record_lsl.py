"""`carlaverse record --lsl NAME`: Lab Streaming Layer streams into the recording.

The flags, and the glue between the recorder and `carlaverse.study.lsl_record`: streams are
found before the session is opened (a missing one fails at once, naming it, with nothing
written), then recorded into the same MCAP as the session's keys, on `lsl/<name>`.
"""

from __future__ import annotations

import argparse

from carlaverse.study.lsl_api import LslConfigConflict, LslNetwork, LslUnavailable
from carlaverse.study.lsl_record import StreamMissing
from carlaverse.study.lsl_session import DEFAULT_WAIT_S, LslSession

# What --lsl can fail with before anything starts: a usage error (exit 2), naming the fix.
LSL_ERRORS = (LslUnavailable, LslConfigConflict, StreamMissing)


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


def prepare_lsl(args: argparse.Namespace) -> LslSession | None:
    """None when no --lsl flag was given; else the streams, found (StreamMissing otherwise)."""
    if not args.lsl and not args.lsl_markers:
        return None
    network = LslNetwork(args.lsl_scope, args.lsl_session_id)
    return LslSession.prepare(
        args.lsl, network=network, wait_s=args.lsl_wait, markers=args.lsl_markers
    )
