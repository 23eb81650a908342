"""`carlaverse demo`: a whole session on this machine, no hardware, one command.

Starts a router, an authority and several nodes as separate processes (exactly what a lab
would run, on loopback), watches the session as an observer to show progress, and prints a
summary of what every node saw. Ctrl-C stops everything; no process is left behind.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from carlaverse.cli.common import StopSignal, fail, stop_on_signals
from carlaverse.cli.demo_summary import format_summary, summarise
from carlaverse.config import ConfigError, load_config
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session

DEFAULT_NODES = "scripted,scripted,scripted"
ERROR_TAIL_LINES = 20  # stderr lines kept per child, to say why it failed
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
        default=30.0,
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


@dataclass
class Child:
    name: str
    proc: subprocess.Popen[str]
    role: str  # router | authority | node | tool
    out: list[str] = field(default_factory=list)
    err: deque[str] = field(default_factory=lambda: deque(maxlen=ERROR_TAIL_LINES))
    readers: list[threading.Thread] = field(default_factory=list)

    def last_error(self) -> str:
        """The child's last non-empty stderr line: a command's one-line error says why."""
        lines = [line.strip() for line in self.err if line.strip()]
        return lines[-1] if lines else ""


class ChildFailed(RuntimeError):
    """A child the session needs did not start; the message says which and why."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _spawn(name: str, role: str, argv: list[str]) -> Child:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    cmd = [sys.executable, "-m", "carlaverse", *argv]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    child = Child(name, proc, role)
    for stream, sink in ((proc.stdout, child.out), (proc.stderr, child.err)):
        reader = threading.Thread(target=_drain, args=(stream, sink), daemon=True)
        reader.start()
        child.readers.append(reader)
    return child


def _await_line(child: Child, prefix: str, timeout: float, stop: threading.Event) -> None:
    """Wait until `child` prints a stderr line starting with `prefix`; fail if it exits first
    or the timeout passes (a signal ends the wait too: the caller stops everything)."""
    deadline = time.monotonic() + timeout
    while not any(line.startswith(prefix) for line in list(child.err)):
        if child.proc.poll() is not None:
            _finish_reading(child)
            raise ChildFailed(
                f"the {child.name} exited ({child.proc.returncode}): {child.last_error()}"
            )
        if time.monotonic() > deadline:
            raise ChildFailed(f"the {child.name} did not start within {timeout:.0f} s")
        if stop.wait(0.05):
            return


def _drain(stream: Any, sink: list[str] | deque[str]) -> None:
    for line in stream:
        sink.append(line)


def _scripted_config(index: int, count: int, directory: Path) -> Path:
    # Concentric circles, evenly phased, so the demo's actors never sit on top of each other.
    path = {
        "type": "circle",
        "center": [0.0, 0.0],
        "radius": 25.0 + 6.0 * index,
        "speed_mps": 14.0 if index % 2 == 0 else -12.0,
        "phase_deg": 360.0 * index / max(1, count),
    }
    target = directory / f"scripted-{index + 1}.yaml"
    target.write_text(yaml.safe_dump({"path": path}))
    return target


def _node_argv(
    kind: str, node_id: str, config: Path | None, endpoint: str, args: argparse.Namespace
) -> list[str]:
    argv = [
        "join",
        kind,
        "--id",
        node_id,
        "--session",
        args.session,
        "--connect",
        endpoint,
        "--duration",
        str(args.duration),
        "--json",
    ]
    configs = dict(item.split("=", 1) for item in args.node_config)
    if kind in configs:  # the user's config wins over the demo's generated one
        argv += ["--config", configs[kind]]
    elif config is not None:
        argv += ["--config", str(config)]
    elif kind not in ("scripted", "observer"):
        argv += ["--backend", "sim"]  # no hardware here: the kind's honest simulated devices
    return argv


def authority_argv(args: argparse.Namespace, endpoint: str) -> list[str]:
    """The demo authority's `carlaverse` arguments (the launcher's demo runs the same)."""
    return ["authority", "--session", args.session, "--connect", endpoint,
            "--scenario", args.scenario, "--json"]  # fmt: skip


def node_plan(
    kinds: list[str], endpoint: str, args: argparse.Namespace, directory: Path
) -> list[tuple[str, list[str]]]:
    """(node id, `carlaverse` arguments) of each demo node; scripted paths go to `directory`."""
    scripted = [i for i, k in enumerate(kinds) if k == "scripted"]
    plan = []
    for i, kind in enumerate(kinds):
        node_id = f"{kind}-{i + 1}"
        config = (
            _scripted_config(scripted.index(i), len(scripted), directory)
            if kind == "scripted"
            else None
        )
        plan.append((node_id, _node_argv(kind, node_id, config, endpoint, args)))
    return plan


def check_nodes(kinds: list[str], node_configs: list[str]) -> str:
    """Why the requested nodes cannot start ("" if they can): unknown kind, bad config."""
    if not kinds:
        return "--nodes names no node kind"
    try:
        for kind in kinds:
            load_node_kind(kind)
        for item in node_configs:
            kind, sep, path = item.partition("=")
            if not sep or not kind or not path:
                return f"--node-config takes KIND=FILE, got {item!r}"
            if kind not in kinds:
                return f"--node-config {item!r}: no {kind!r} node in --nodes {','.join(kinds)}"
            load_config(path, load_node_kind(kind).config_type)
    except (UnknownNodeKind, ConfigError) as exc:
        return str(exc)
    return ""


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
            _stop_all(children)
            return fail("demo", str(exc), 1)
        finally:
            _stop_all(children)
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
    stop: threading.Event,
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
        _await_line(recorder, RECORDER_READY, READY_TIMEOUT_S, stop)
    if args.rrd:
        children.append(
            _spawn(
                "viewer",
                "tool",
                ["view", "--session", args.session, "--connect", endpoint, "--save", args.rrd],
            )
        )
    authority = _spawn("authority", "authority", authority_argv(args, endpoint))
    children.append(authority)
    # The nodes once the authority ticks: its start (SUMO, the map) takes seconds, and a node
    # counts its --duration from its own start, so nodes started with it spent much of a short
    # demo waiting to be admitted.
    _await_line(authority, AUTHORITY_READY, READY_TIMEOUT_S, stop)
    ids = []
    for node_id, argv in node_plan(kinds, endpoint, args, tmp):
        children.append(_spawn(node_id, "node", argv))
        ids.append(node_id)
    watched = _watch(args, endpoint, ids, children, stop)
    nodes = _collect_nodes(children, args.duration + 60.0, stop)
    # The authority first, so its last puts still reach the router and the recorder; then the
    # tools that listen; the router that carries it all last. Stopped together, a loaded host
    # let the authority count a final put as sent after the recorder had gone.
    for role in ("authority", "tool", "router"):
        _stop_all([c for c in children if c.role == role])
    authority = next(c for c in children if c.role == "authority")
    tools = [c for c in children if c.role == "tool"]
    return summarise(
        ids,
        nodes,
        _parse_json(authority),
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
    _stop_all(nodes)  # on a signal or the deadline: SIGINT all at once, kill the deaf
    out: dict[str, Any] = {}
    for child in nodes:
        _finish_reading(child)
        out[child.name] = {
            "exit_code": child.proc.returncode,
            "summary": _parse_json(child),
            "error": child.last_error(),
        }
    return out


def _finish_reading(child: Child, timeout: float = 2.0) -> None:
    """Let the reader threads take the last lines of an exited child (its pipes close)."""
    deadline = time.monotonic() + timeout
    for reader in child.readers:
        reader.join(max(0.0, deadline - time.monotonic()))


def _parse_json(child: Child) -> dict[str, Any] | None:
    text = "".join(child.out)
    start = text.find("{")
    try:
        return json.loads(text[start:]) if start >= 0 else None
    except json.JSONDecodeError:
        return None


def _stop_all(children: list[Child]) -> None:
    """SIGINT every running child at once; kill those still running after the grace."""
    for child in children:
        if child.proc.poll() is None:
            child.proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + STOP_GRACE_S
    for child in children:
        try:
            child.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            child.proc.kill()
            child.proc.wait()
