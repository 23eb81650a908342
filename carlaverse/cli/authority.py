"""`carlaverse authority`: run a session's authority (membership + the global domain)."""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TextIO

from carlaverse.authority.domain import EmptyDomain, GlobalDomain
from carlaverse.authority.pose_digest import DIGEST_PERIOD_S
from carlaverse.authority.service import Authority, AuthoritySettings
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
from carlaverse.config import ConfigError
from carlaverse.keys import AUTHORITY_ID, KeySpaceError, check_token
from carlaverse.traffic.engine import EngineFailed
from carlaverse.transport.clock import WallAlignedClock
from carlaverse.transport.session import (
    FabricError,
    FabricUnreachable,
    await_mesh,
    build_config,
    open_session,
)

log = logging.getLogger(__name__)

# [s] the most the authority waits to reach anyone before its first tick; one started before
# its router or its peers goes on ticking (later arrivals get the state in the snapshot).
MESH_TIMEOUT_S = 2.0


def bounded(
    kind: type[int] | type[float], low: float, high: float, means: str
) -> Callable[[str], int | float]:
    """An argparse type: a `kind` number from `low` to `high`; `means` says what the bounds
    are, in the one-line error a wrong value gets."""

    def parse(text: str) -> int | float:
        try:
            value = kind(text)
        except ValueError:
            number = "a whole number" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {number} ({means})") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: {means}")
        return value

    return parse


# SCHED_FIFO priority: 0 leaves the scheduling alone.
fifo_priority = bounded(int, 0, 99, "0 (normal) or 1-99")
digest_ms = bounded(float, 0, 1000, "0 (off) to 1000 ms")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Run the authority of a session: joins, presence, the session clock, despawns, and the "
        "global domain (SUMO traffic, lights, weather, collisions) of a scenario."
    )
    parser.add_argument(
        "--scenario",
        default="town",
        help="scenario name (shipped), YAML file, or 'none' for membership only (default: town)",
    )
    parser.add_argument("--seed", type=int, help="override the scenario's random seed")
    parser.add_argument("--tick-hz", type=float, help="tick rate (default: scenario's, else 50)")
    parser.add_argument(
        "--despawn-timeout",
        type=float,
        metavar="S",
        help="despawn a silent node after S seconds (default: scenario's, else 3)",
    )
    parser.add_argument(
        "--tick-priority",
        type=fifo_priority,
        default=0,
        metavar="N",
        help="run the tick thread real-time (SCHED_FIFO N, 1-99) where allowed, else at nice "
        "-10: ticks on time on a machine shared with nodes, at their cost (default: 0, normal)",
    )
    parser.add_argument(
        "--digest-ms",
        type=digest_ms,
        default=DIGEST_PERIOD_S * 1e3,
        metavar="MS",
        help="relay every pose, gathered for MS milliseconds, as one message on world/@egos to "
        "nodes that hear the whole session and ask for it (`--pose-digest`); nothing is "
        "relayed while no one asks. 0 turns it off (default: %(default)g)",
    )
    add_fabric_args(parser)
    add_output_args(parser)


def load_domain(scenario: str, seed: int | None) -> GlobalDomain:
    if scenario == "none":
        return EmptyDomain()
    try:
        from carlaverse.authority.traffic_domain import load_domain as load_traffic_domain
    except ModuleNotFoundError as exc:
        raise ConfigError(
            scenario,
            f"running a scenario needs SUMO ({exc.name} is missing): "
            "pip install 'carlaverse[authority]', or pass --scenario none",
        ) from exc
    from carlaverse.traffic.sumo_tools import SumoMissingError, SumoToolError

    try:
        return load_traffic_domain(scenario, seed_override=seed)
    except (SumoMissingError, SumoToolError) as exc:
        raise ConfigError(scenario, str(exc)) from exc


def traffic_report(domain: GlobalDomain) -> dict[str, Any] | None:
    """The traffic domain's counters; None for `--scenario none` (no traffic to count)."""
    report = getattr(domain, "report", None)  # TrafficDomain's, imported only with SUMO
    return report() if report is not None else None


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:  # what SUMO or a library prints must not reach it
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    session_name = args.session or "default"
    try:
        check_token(session_name, "session name")
        fabric = fabric_from_args(args, identity=AUTHORITY_ID)
        build_config(fabric)  # a bad endpoint is reported before SUMO starts
        domain = load_domain(args.scenario, args.seed)
    except (ConfigError, FabricError, KeySpaceError) as exc:
        return fail("authority", str(exc))
    stop = stop_on_signals()
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:
        session = open_session(fabric, stop, deadline, say("authority"))
    except FabricUnreachable as exc:
        return fail("authority", str(exc), stop.exit_code() if stop.is_set() else Exit.NOT_ADMITTED)
    except FabricError as exc:
        return fail("authority", str(exc), Exit.FABRIC)
    # Its first tick puts the lights and the weather, reliable: only peers it already has a
    # link to hear them (a router does not relay between peers).
    await_mesh(session, stop, MESH_TIMEOUT_S)
    params = getattr(domain, "session_params", None)
    settings = AuthoritySettings(
        session=session_name,
        tick_hz=args.tick_hz or getattr(params, "tick_hz", 50.0),
        despawn_timeout_s=args.despawn_timeout or getattr(params, "despawn_timeout_s", 3.0),
        tick_priority=args.tick_priority,
        digest_period_s=args.digest_ms / 1e3,
    )
    authority = Authority(session, settings, WallAlignedClock(), domain).start()

    def stop_when_asked() -> None:
        stop.wait()
        authority.stop()

    watcher = threading.Thread(target=stop_when_asked, daemon=True)
    watcher.start()
    print(
        f"authority of session {session_name!r} ticking at {settings.tick_hz:g} Hz "
        f"(scenario {args.scenario})",
        file=sys.stderr,
        flush=True,
    )
    broke = ""
    try:
        authority.run(args.duration)
    except EngineFailed as exc:  # SUMO's process died: no traffic to run, said in a line
        broke = str(exc).splitlines()[0]
    finally:
        authority.close()
        session.close()
    if broke:
        return fail("authority", f"traffic stopped: {broke}", Exit.FAILED)
    summary = authority.summary()
    if args.json:
        print_json(
            {
                "tick": summary,
                "scheduling": authority.scheduling,
                "despawned": authority.despawned,
                "dropped": authority.dropped,
                "sent": authority.outbox.sent,
                "traffic": traffic_report(domain),
            },
            out,
        )
    else:
        print(
            f"authority: {summary.ticks} ticks, p50 {summary.tick_p50_ms} ms, "
            f"p99 {summary.tick_p99_ms} ms, {summary.overruns} overruns",
            file=sys.stderr,
        )
    return Exit.OK
