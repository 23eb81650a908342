"""`carlaverse demo`: a whole session on this machine, no hardware, one command.

Starts a router, an authority and several nodes as separate processes (exactly what a lab
would run, on loopback), watches the session as an observer to show progress, and prints a
summary of what every node saw. Ctrl-C stops everything; no process is left behind.
"""

from __future__ import annotations

import argparse
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from carlaverse.cli.common import StopSignal, fail, stop_on_signals
from carlaverse.cli.demo_summary import format_summary, summarise
from carlaverse.demo_plan import DEFAULT_NODES, DemoChoices, authority_argv, check_nodes, node_plan
from carlaverse.procs import Child, ChildFailed, free_port, stop_children
from carlaverse.procs import start as start_child
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session

STOP_GRACE_S = 10.0  # [s] a child stopped by SIGINT is killed after this
READY_TIMEOUT_S = 60.0  # [s] for the recorder or authority to say it is ready (loaded host)
RECORDER_READY = "recording session "  # what `record` prints once its subscribers are declared
AUTHORITY_READY = "authority of session "  # what `authority` prints once it ticks


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Run a local demo session: a router, an authority and scripted nodes as separate "
        "processes on 127.0.0.1, then print what every node saw."
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=15.0,
        metavar="S",
        help="how long the nodes run (default 30)",
    )
    parser.add_argument(
        "--nodes",
        default=DEFAULT_NODES,
        metavar="KIND,KIND,...",
        help=f"node kinds that join, one process each (default {DEFAULT_NODES})",
    )
    parser.add_argument(
        "--scenario",
        default="town",
        help="authority scenario (default town; 'none' for membership only)",
    )
    parser.add_argument("--session", default="demo", help="session name (default demo)")
    parser.add_argument("--record", metavar="FILE.mcap", help="also record the session to MCAP")
    parser.add_argument("--rrd", metavar="FILE.rrd", help="also save a Rerun recording")
    parser.add_argument(
        "--node-config",
        action="append",
        default=[],
        metavar="KIND=FILE",
        help="config for every node of KIND (repeatable); kinds with devices "
        "and no config run headless on their sim backend",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")


def run(args: argparse.Namespace) -> int:
    kinds = [k.strip() for k in args.nodes.split(",") if k.strip()]
    problem = check_nodes(kinds, args.node_config)
    if problem:
        return fail("demo", problem)
    stop = stop_on_signals()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    children: list[Child] = []
    with tempfile.TemporaryDirectory(prefix="carlaverse-demo-") as tmp:
        try:
            summary = _run_session(args, kinds, endpoint, Path(tmp), children, stop)
        except ChildFailed as exc:
            return fail("demo", str(exc), 1)
        finally:
            stop_children(children, STOP_GRACE_S)
    print(format_summary(summary, args.json), flush=True)
    if summary["interrupted"]:
        return stop.exit_code()
    return 0 if summary["ok"] else 1


def _run_session(
    args: argparse.Namespace,
    kinds: list[str],
    endpoint: str,
    tmp: Path,
    children: list[Child],
    stop: StopSignal,
) -> dict[str, Any]:
    children.append(_spawn("router", "router", ["router", "--listen", endpoint]))
    # The listeners before the authority, and the recorder confirmed subscribed: started
    # together, a loaded host let the authority's first reliable put (world/lights at t = 0)
    # reach the router before the recorder's subscription did, and the recording lost it.
    if args.record:
        recorder = _spawn(
            "recorder", "tool", ["record", "--session", args.session, "--connect", endpoint,
                                 "-o", args.record],
        )  # fmt: skip
        children.append(recorder)
        recorder.wait_for_line(RECORDER_READY, READY_TIMEOUT_S, stop=stop)
    if args.rrd:
        children.append(
            _spawn(
                "viewer",
                "tool",
                ["view", "--session", args.session, "--connect", endpoint, "--save", args.rrd],
            )
        )
    authority = _spawn(
        "authority", "authority", authority_argv(args.session, args.scenario, endpoint)
    )
    children.append(authority)
    # The nodes once the authority ticks: its start (SUMO, the map) takes seconds, and a node
    # counts its --duration from its own start, so nodes started with it spent much of a short
    # demo waiting to be admitted.
    authority.wait_for_line(AUTHORITY_READY, READY_TIMEOUT_S, stop=stop)
    ids = []
    for node_id, argv in node_plan(kinds, endpoint, _choices(args), tmp):
        children.append(_spawn(node_id, "node", argv))
        ids.append(node_id)
    watched = _watch(args, endpoint, ids, children, stop)
    nodes = _collect_nodes(children, args.duration + 60.0, stop)
    # The authority first, so its last puts still reach the router and the recorder; then the
    # tools that listen; the router that carries it all last. Stopped together, a loaded host
    # let the authority count a final put as sent after the recorder had gone.
    for role in ("authority", "tool", "router"):
        stop_children([c for c in children if c.role == role], STOP_GRACE_S)
    authority = next(c for c in children if c.role == "authority")
    tools = [c for c in children if c.role == "tool"]
    return summarise(
        ids,
        nodes,
        authority.json(),
        watched,
        {c.name: c.proc.returncode for c in tools},
        {c.name: c.last_error() for c in tools},
        interrupted=_signal_name(stop),
    )


def _signal_name(stop: StopSignal) -> str:
    return signal.Signals(stop.signum).name if stop.is_set() and stop.signum else ""


def _watch(
    args: argparse.Namespace,
    endpoint: str,
    ids: list[str],
    children: list[Child],
    stop: threading.Event,
) -> dict[str, Any]:
    """Observe the session in-process for progress; returns what the observer saw."""
    session = open_session(FabricSettings(connect=[endpoint]))
    settings = NodeSettings(
        node_id="demo-watch", session=args.session, kind="observer", actor_kind=""
    )
    client = NodeClient(session, settings, MonotonicClock()).start()
    started = time.monotonic()
    max_seen = 0
    try:
        while not stop.is_set() and any(
            c.proc.poll() is None for c in children if c.role == "node"
        ):
            client.update()
            here = sorted(client.world.egos)
            max_seen = max(max_seen, len(here))
            if not args.quiet:
                _progress(time.monotonic() - started, args.duration, here, len(ids))
            stop.wait(0.5)
    finally:
        if not args.quiet and sys.stderr.isatty():
            print(file=sys.stderr)
        client.close()
        session.close()
    return {"max_actors_live": max_seen}


def _progress(elapsed: float, duration: float, live: list[str], expected: int) -> None:
    line = f"[{elapsed:5.1f}/{duration:g} s] actors live: {len(live)}/{expected} {' '.join(live)}"
    if sys.stderr.isatty():
        print(f"\r{line[:100]:<100}", end="", file=sys.stderr, flush=True)
    elif int(elapsed * 2) % 10 == 0:  # every ~5 s when logging to a file
        print(line, file=sys.stderr, flush=True)


def _collect_nodes(children: list[Child], timeout: float, stop: threading.Event) -> dict[str, Any]:
    """Wait for the nodes to finish (or a signal), then read each one's exit and summary."""
    nodes = [c for c in children if c.role == "node"]
    deadline = time.monotonic() + timeout
    while any(c.proc.poll() is None for c in nodes) and time.monotonic() < deadline:
        if stop.wait(0.1):
            break
    stop_children(nodes, STOP_GRACE_S)  # on a signal or the deadline: SIGINT all, kill the deaf
    out: dict[str, Any] = {}
    for child in nodes:
        out[child.name] = {
            "exit_code": child.proc.returncode,
            "summary": child.json(),
            "error": child.last_error(),
        }
    return out


def _spawn(name: str, role: str, argv: list[str]) -> Child:
    return start_child(argv, name=name, role=role)


def _choices(args: argparse.Namespace) -> DemoChoices:
    return DemoChoices(args.session, args.scenario, args.duration, tuple(args.node_config))
