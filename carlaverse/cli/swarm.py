"""`carlaverse swarm`: N synthetic egos in one process, for measuring the fabric at scale."""

from __future__ import annotations

import argparse
import sys
import threading
import time
from typing import TextIO

import msgspec

from carlaverse.cli.common import (
    add_fabric_args,
    add_output_args,
    fabric_from_args,
    fail,
    json_stdout,
    print_json,
    say,
    stop_on_signals,
)
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError, invalid_at
from carlaverse.keys import KeySpaceError
from carlaverse.swarm.generator import Swarm, SwarmReport, SwarmSettings
from carlaverse.transport.session import FabricError, FabricUnreachable, open_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Run N synthetic egos in one process: each joins the session like a node (join query, "
        "liveliness token, leave) and publishes its pose while driving around a city block."
    )
    parser.add_argument("--egos", type=int, default=16, metavar="N", help="egos (default 16)")
    parser.add_argument(
        "--rate", type=float, default=50.0, metavar="HZ", help="poses per ego per second (50)"
    )
    parser.add_argument(
        "--spread",
        type=float,
        default=1000.0,
        metavar="M",
        help="side of the square the egos drive in, metres (default 1000)",
    )
    parser.add_argument(
        "--block", type=float, default=150.0, metavar="M", help="street grid spacing (150 m)"
    )
    parser.add_argument(
        "--origin",
        type=float,
        nargs=2,
        default=(0.0, 0.0),
        metavar=("X", "Y"),
        help="south-west corner of the square, metres (a junction of a grid town: default 0 0)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the egos' blocks and speeds")
    parser.add_argument("--prefix", default="swarm", help="ego ids are PREFIX-INDEX (swarm)")
    parser.add_argument(
        "--express",
        action="store_true",
        help="send every pose in a frame of its own, as N separate machines would; without it "
        "the egos' poses share frames, which makes receiving them cheaper than it would be",
    )
    add_fabric_args(parser)
    add_output_args(parser)


def settings_from_args(args: argparse.Namespace) -> SwarmSettings:
    """The swarm's settings; raises ConfigError naming the flag that is out of range."""
    given = {"session": ("--session", args.session or "default"), "egos": ("--egos", args.egos),
             "rate_hz": ("--rate", args.rate), "spread_m": ("--spread", args.spread),
             "block_m": ("--block", args.block), "origin": ("--origin", tuple(args.origin)),
             "seed": ("--seed", args.seed), "prefix": ("--prefix", args.prefix),
             "express": ("--express", args.express)}  # fmt: skip
    try:
        return msgspec.convert({name: value for name, (_, value) in given.items()}, SwarmSettings)
    except msgspec.ValidationError as exc:
        path, message = invalid_at(str(exc))
        field = path.split(".")[0].split("[")[0]
        if field not in given:
            raise ConfigError("command line", str(exc)) from exc
        flag, value = given[field]  # name what the user typed, not the settings field
        raise ConfigError(flag, f"{message} (got {value!r})") from exc


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    try:
        settings = settings_from_args(args)
        fabric = fabric_from_args(args, identity=settings.prefix)
    except (ConfigError, FabricError) as exc:
        return fail("swarm", str(exc))
    stop = stop_on_signals()
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:
        session = open_session(fabric, stop, deadline, say("swarm"))
    except FabricUnreachable as exc:
        return fail("swarm", str(exc), stop.exit_code() if stop.is_set() else Exit.NOT_ADMITTED)
    except FabricError as exc:
        return fail("swarm", str(exc), Exit.FABRIC)
    try:
        return _run_swarm(session, settings, stop, args, out)
    except KeySpaceError as exc:
        return fail("swarm", str(exc))
    finally:
        session.close()


def _run_swarm(
    session: object,
    settings: SwarmSettings,
    stop: threading.Event,
    args: argparse.Namespace,
    out: TextIO,
) -> int:
    swarm = Swarm(session, settings)  # type: ignore[arg-type]
    joined = swarm.join()
    if joined == 0 and swarm.members.refused:
        reason = next(iter(swarm.members.refused.values()))
        return fail("swarm", f"the authority refused every ego: {reason}", Exit.REFUSED)
    print(
        f"carlaverse swarm: {joined} of {settings.egos} egos joined session "
        f"{settings.session!r}; publishing at {settings.rate_hz:g} Hz",
        file=sys.stderr,
        flush=True,
    )

    def stop_when_asked() -> None:
        stop.wait()
        swarm.stop()

    watcher = threading.Thread(target=stop_when_asked, daemon=True)
    watcher.start()
    report = swarm.run(args.duration)
    if args.json:
        print_json(report, out)
    else:
        print(summary_text(report), file=sys.stderr)
    return Exit.OK


def summary_text(r: SwarmReport) -> str:
    refused = f", {len(r.refused)} refused" if r.refused else ""
    return (
        f"carlaverse swarm: {r.joined} of {r.egos} egos joined{refused}, {r.left} left; "
        f"{r.poses_sent} poses in {r.seconds:.1f} s ({r.poses_per_s:.0f}/s, "
        f"{r.offered_fraction:.1%} of the rate), {r.late_slots} late slots, "
        f"{r.send_us_per_pose:.1f} µs per pose sent, CPU {r.cpu_fraction:.0%} of a core"
    )
