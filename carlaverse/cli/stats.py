"""`carlaverse stats`: per-node rate, one-way latency, jitter and loss, as an observer sees them."""

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
    attend,
    fabric_from_args,
    fail,
    json_stdout,
    print_json,
    reached_nothing,
    stop_on_signals,
)
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, check_token
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricError, FabricUnreachable, build_config
from carlaverse.world.stream_summary import StreamSummary, summaries


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Join a session as an observer and report, per node: pose rate, one-way latency "
        "p50/p99 (from session time stamps), jitter, loss (sequence gaps) and last seen."
    )
    parser.add_argument("--id", dest="node_id", default="stats", help="observer id (default stats)")
    parser.add_argument(
        "--interval",
        type=float,
        default=2.0,
        metavar="S",
        help="print a table every S seconds (default 2)",
    )
    parser.add_argument(
        "--pose-digest",
        action="store_true",
        help="take the poses from the authority's pose digest (world/@egos), dozens to a "
        "message: far less CPU with hundreds of nodes, but latency then includes the relay "
        "(about 1-2 ms more); falls back to a sample per pose if the authority relays none",
    )
    add_fabric_args(parser)
    add_output_args(parser, duration=10.0)
    parser.epilog = "Exit 3 when no router or peer was reached for the whole run."


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    settings = NodeSettings(
        node_id=args.node_id, session=args.session or "default", kind="observer", actor_kind="",
        pose_digest=args.pose_digest,
    )  # fmt: skip
    try:
        check_token(settings.node_id, "observer id (--id)")
        if settings.node_id == AUTHORITY_ID:
            raise KeySpaceError(f"observer id (--id) {AUTHORITY_ID!r} is the authority's")
        check_token(settings.session, "session name")
        fabric = fabric_from_args(args)
        build_config(fabric)
    except (KeySpaceError, FabricError, ConfigError) as exc:  # ConfigError: --roster problems
        return fail("stats", str(exc))
    stop = stop_on_signals()
    deadline = time.monotonic() + args.duration
    try:
        session, notice = attend("stats", fabric, Keys(settings.session), stop, deadline)
    except FabricUnreachable as exc:
        return fail("stats", str(exc), stop.exit_code() if stop.is_set() else Exit.FABRIC)
    except FabricError as exc:
        return fail("stats", str(exc), Exit.FABRIC)
    client = NodeClient(session, settings, MonotonicClock()).start()
    try:
        result = _observe(args, client, stop, deadline)
        unreached = reached_nothing(notice, fabric)
    finally:
        notice.close()
        client.close()
        session.close()
    if unreached:  # an empty table would read as a session where nobody publishes
        code = stop.exit_code() if stop.is_set() else Exit.FABRIC
        return fail("stats", f"{unreached}: nothing measured", code)
    if args.json:
        # dropped, rejected, handler_errors, impulses_accepted: what the fabric layer counted
        print_json({"nodes": result, **msgspec.structs.asdict(client.counters())}, out)
    else:
        _print_table(result)
    return Exit.OK


def _observe(
    args: argparse.Namespace, client: NodeClient, stop: threading.Event, deadline: float
) -> dict[str, StreamSummary]:
    """Print a table every --interval until the deadline or a signal; the final summaries."""
    next_print = time.monotonic()
    while not stop.is_set() and time.monotonic() < deadline:
        now = client.update()
        if not args.json and time.monotonic() >= next_print:
            _print_table(summaries(client.world.stats, now))
            next_print += args.interval
        stop.wait(0.05)
    return summaries(client.world.stats, client.update())


def _print_table(rows: dict[str, StreamSummary]) -> None:
    print(
        f"{'node':<16} {'rate Hz':>8} {'p50 ms':>8} {'p99 ms':>8} {'jitter':>8} {'loss':>7} "
        f"{'last s':>7}"
    )
    for node, s in rows.items():
        print(
            f"{node:<16} {s.rate_hz:>8.1f} {s.latency_p50_ms:>8.3f} {s.latency_p99_ms:>8.3f} "
            f"{s.jitter_ms:>8.3f} {s.loss:>7.2%} {s.last_seen_s:>7.2f}"
        )
    if not rows:
        print("(no node has published a pose yet)")
    sys.stdout.flush()
