"""`carlaverse stats`: per-node rate, one-way latency, jitter and loss, as an observer sees them."""

from __future__ import annotations

import argparse
import sys
import time

from carlaverse.cli.common import (
    add_fabric_args,
    add_output_args,
    fabric_from_args,
    fail,
    print_json,
    stop_on_signals,
)
from carlaverse.config import ConfigError
from carlaverse.fabric.clock import MonotonicClock
from carlaverse.fabric.node_client import NodeClient, NodeSettings
from carlaverse.fabric.session import FabricError, open_session
from carlaverse.fabric.stats import StreamSummary


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
    add_fabric_args(parser)
    add_output_args(parser, duration=10.0)


def run(args: argparse.Namespace) -> int:
    settings = NodeSettings(
        node_id=args.node_id, session=args.session or "default", kind="observer", actor_kind=""
    )
    try:
        session = open_session(fabric_from_args(args))
    except FabricError as exc:
        return fail("stats", str(exc), 3)
    except ConfigError as exc:  # --roster: not in it, or certificate files missing
        return fail("stats", str(exc))
    stop = stop_on_signals()
    client = NodeClient(session, settings, MonotonicClock()).start()
    started = next_print = time.monotonic()
    try:
        while not stop.is_set() and time.monotonic() - started < args.duration:
            now = client.update()
            if not args.json and time.monotonic() >= next_print:
                _print_table(_summaries(client, now))
                next_print += args.interval
            stop.wait(0.05)
        result = _summaries(client, client.update())
    finally:
        client.close()
        session.close()
    if args.json:
        print_json({"nodes": result, "dropped": dict(client.dropped)})
    else:
        _print_table(result)
    return 0


def _summaries(client: NodeClient, now: float) -> dict[str, StreamSummary]:
    return {node: stats.summary(now) for node, stats in sorted(client.world.stats.items())}


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
