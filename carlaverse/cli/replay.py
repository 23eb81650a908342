"""`carlaverse replay`: republish an MCAP recording into a live session, with its timing.

The replay is that session's authority (`recording/replay_authority.py`): observers join it,
its clock tells the recorded session time being played, and it answers snapshot, map,
scenario and configs from the recording; so `view --session`, `render --connect`, `audio`
and `join observer` work on `<recorded>-replay` as on a live session.
"""

from __future__ import annotations

import argparse
import signal
import threading
from collections.abc import Mapping
from pathlib import Path

import zenoh

from carlaverse.cli.common import add_fabric_args, fabric_from_args, fail, tell
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, check_token, parse
from carlaverse.recording.reading import iter_samples, read_channels
from carlaverse.recording.replay import Replayer, ReplayStats, default_target
from carlaverse.recording.sink import RecordingError
from carlaverse.recording.timeline import receive_offset_ns, recording_start_time
from carlaverse.transport.session import FabricError, await_mesh, open_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, metavar="FILE.mcap", help="recording to replay")
    parser.add_argument(
        "--session",
        help="target session (default: <recorded>-replay, a new one; to replay into the "
        "recorded session itself, name it here explicitly)",
    )
    parser.add_argument(
        "--with-commands",
        action="store_true",
        help="also republish impulse/* and ego/*/override (off by default: they move real "
        "wheels and motion platforms of a live rig)",
    )
    parser.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="time scale: 2 plays twice as fast (default 1; nodes and viewers that join the "
        "replay keep real time, so join one played at 1)",
    )
    parser.add_argument("--loop", action="store_true", help="start over at the end until Ctrl-C")
    parser.add_argument(
        "--no-queries",
        action="store_true",
        help="do not stand in for the session's authority (join, clock, snapshot, map, "
        "scenario, configs from the recording): use when a live authority runs in the target "
        "session",
    )
    parser.add_argument(
        "--id",
        dest="node_id",
        default="replay",
        help="identity in a --roster session (default replay)",
    )
    add_fabric_args(parser, session=False)


def run(args: argparse.Namespace) -> int:
    if args.speed <= 0:
        return fail("replay", f"--speed must be > 0, got {args.speed}")
    if not args.file.is_file():
        return fail("replay", f"{args.file}: no such recording")
    try:
        if args.session:
            check_token(args.session, "session name")
        stats = _replay(args)
    except (KeySpaceError, ConfigError) as exc:  # ConfigError: a --roster problem
        return fail("replay", str(exc))
    except FabricError as exc:
        return fail("replay", str(exc), Exit.FABRIC)
    except RecordingError as exc:
        return fail("replay", str(exc), Exit.FAILED)
    except AuthorityRunning as exc:
        return fail("replay", str(exc), Exit.USAGE)
    extra = f", {stats.withheld} commands withheld" if stats.withheld else ""
    joins = stats.answered["join/accepted"], stats.answered["join/refused"]
    if any(joins):  # a re-join (after a --loop pass) counts again
        extra += f"; joins: {joins[0]} admitted, {joins[1]} refused"
    tell(
        f"replayed {stats.published} samples on {len(stats.per_key)} keys in {stats.passes} "
        f"pass(es); {stats.late} late (worst {stats.max_late_s * 1e3:.1f} ms), "
        f"{stats.skipped} skipped{extra}"
    )
    return Exit.OK


def _replay(args: argparse.Namespace) -> ReplayStats:
    stop = _stop_event()
    channels = read_channels(args.file)
    target = args.session or default_target(recorded_session(channels, args.file))
    fabric = fabric_from_args(args)  # a --roster problem is said before anything else
    tell(f"replaying {args.file} into session {target}")
    if args.speed != 1 and not args.no_queries:
        tell(
            f"--speed {args.speed:g}: a joined node's or viewer's session clock runs in real "
            "time and drifts from this replay's (nodes refuse poses 5 s off their time); "
            "to join the replay, play it at --speed 1"
        )
    offset_ns = receive_offset_ns(args.file)
    session = open_session(fabric)
    replayer = Replayer(
        session,
        target,
        speed=args.speed,
        serve_queries=not args.no_queries,
        with_commands=args.with_commands,
        session_offset_ns=offset_ns,
    )
    try:
        if args.connect and not await_mesh(session, stop):
            raise FabricError(f"could not reach {', '.join(args.connect)} within 10 s")
        if not args.no_queries:
            _check_no_authority(session, Keys(target))
        replayer.preload(iter_samples(args.file, topics=_authority_keys(channels)))
        replayer.prepare(channels, recording_start_time(args.file))
        replayer.wait_for_subscribers(stop)  # best effort: a session may have no listener yet
        return replayer.run(lambda: iter_samples(args.file), stop, loop=args.loop)
    finally:
        replayer.close()
        session.close()


class AuthorityRunning(Exception):
    """The target session has a live authority, and the replay would answer for one too."""


def _check_no_authority(session: zenoh.Session, keys: Keys) -> None:
    """Refuse to stand in for an authority that is there: both would answer every join and
    clock query, and a live driving node could be refused by the replay."""
    for reply in session.liveliness().get(keys.node(AUTHORITY_ID), timeout=1.0):
        if reply.ok is not None:
            raise AuthorityRunning(
                f"session {keys.session!r} has a live authority: the replay would answer its "
                "joins and clock too; pass --no-queries to replay into it, or --session NAME "
                "for a session of its own"
            )


def _authority_keys(channels: Mapping[str, object]) -> list[str]:
    """The recording's `authority/<query>` channels (recorded replies)."""
    out = []
    for key in channels:
        try:
            if parse(key).area == "authority":
                out.append(key)
        except KeySpaceError:
            continue
    return out


def recorded_session(channels: Mapping[str, object], path: Path) -> str:
    """The session the recording was made in, from its keys."""
    for key in channels:
        try:
            return parse(key).session
        except KeySpaceError:
            continue
    raise RecordingError(f"{path} holds no carlaverse key: pass --session NAME to replay it")


def _stop_event() -> threading.Event:
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
    return stop
