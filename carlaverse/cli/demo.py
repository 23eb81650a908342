"""`carlaverse demo`: a whole session on this machine, no hardware, one command.

Starts a router, an authority and several nodes as separate processes (exactly what a lab
would run, on loopback), watches the session as an observer to show progress, and prints a
summary of what every node saw. Ctrl-C stops everything; no process is left behind.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from carlaverse.cli.common import fail, stop_on_signals
from carlaverse.fabric.clock import MonotonicClock
from carlaverse.fabric.node_client import NodeClient, NodeSettings
from carlaverse.fabric.session import FabricSettings, open_session

DEFAULT_NODES = "scripted,scripted,scripted"


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


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _spawn(name: str, role: str, argv: list[str]) -> Child:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    cmd = [sys.executable, "-m", "carlaverse", *argv]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    child = Child(name, proc, role)
    threading.Thread(target=_drain, args=(proc.stdout, child.out), daemon=True).start()
    threading.Thread(target=_drain, args=(proc.stderr, []), daemon=True).start()
    return child


def _drain(stream: Any, sink: list[str]) -> None:
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
    if config is not None:
        argv += ["--config", str(config)]
    elif kind in configs:
        argv += ["--config", configs[kind]]
    elif kind not in ("scripted", "observer"):
        argv += ["--backend", "sim"]  # no hardware here: the kind's honest simulated devices
    return argv


def run(args: argparse.Namespace) -> int:
    kinds = [k.strip() for k in args.nodes.split(",") if k.strip()]
    if not kinds:
        return fail("demo", "--nodes names no node kind")
    bad = [item for item in args.node_config if "=" not in item]
    if bad:
        return fail("demo", f"--node-config takes KIND=FILE, got {bad[0]!r}")
    stop = stop_on_signals()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    children: list[Child] = []
    with tempfile.TemporaryDirectory(prefix="carlaverse-demo-") as tmp:
        try:
            summary = _run_session(args, kinds, endpoint, Path(tmp), children, stop)
        finally:
            _stop_all(children)
    _print_summary(summary, args.json)
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
    authority_argv = [
        "authority",
        "--session",
        args.session,
        "--connect",
        endpoint,
        "--scenario",
        args.scenario,
        "--json",
    ]
    children.append(_spawn("authority", "authority", authority_argv))
    if args.record:
        children.append(
            _spawn(
                "recorder",
                "tool",
                ["record", "--session", args.session, "--connect", endpoint, "-o", args.record],
            )
        )
    if args.rrd:
        children.append(
            _spawn(
                "viewer",
                "tool",
                ["view", "--session", args.session, "--connect", endpoint, "--save", args.rrd],
            )
        )
    scripted = [i for i, k in enumerate(kinds) if k == "scripted"]
    ids = []
    for i, kind in enumerate(kinds):
        node_id = f"{kind}-{i + 1}"
        config = (
            _scripted_config(scripted.index(i), len(scripted), tmp) if kind == "scripted" else None
        )
        children.append(_spawn(node_id, "node", _node_argv(kind, node_id, config, endpoint, args)))
        ids.append(node_id)
    watched = _watch(args, endpoint, ids, children, stop)
    nodes = _collect_nodes(children, args.duration + 60.0, stop)
    _stop_all([c for c in children if c.role != "node"], keep=True)
    authority = next(c for c in children if c.role == "authority")
    return _summarise(ids, nodes, _parse_json(authority), watched, children)


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
    deadline = time.monotonic() + timeout
    out: dict[str, Any] = {}
    for child in (c for c in children if c.role == "node"):
        while child.proc.poll() is None and time.monotonic() < deadline and not stop.is_set():
            time.sleep(0.1)
        if child.proc.poll() is None:
            child.proc.send_signal(signal.SIGINT)
            child.proc.wait(timeout=10)
        time.sleep(0.05)  # let the reader thread take the last lines
        out[child.name] = {"exit_code": child.proc.returncode, "summary": _parse_json(child)}
    return out


def _parse_json(child: Child) -> dict[str, Any] | None:
    text = "".join(child.out)
    start = text.find("{")
    try:
        return json.loads(text[start:]) if start >= 0 else None
    except json.JSONDecodeError:
        return None


def _stop_all(children: list[Child], keep: bool = False) -> None:
    for child in children:
        if child.proc.poll() is None:
            child.proc.send_signal(signal.SIGINT)
    for child in children:
        try:
            child.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.proc.kill()
            child.proc.wait()
    if keep:
        time.sleep(0.1)


def _summarise(
    ids: list[str],
    nodes: dict[str, Any],
    authority: dict[str, Any] | None,
    watched: dict[str, Any],
    children: list[Child],
) -> dict[str, Any]:
    actors = [i for i in ids if not i.startswith("observer")]
    table = {}
    all_seen = True
    for node_id in ids:
        entry = nodes.get(node_id, {})
        summary = entry.get("summary") or {}
        seen = set(summary.get("actors_seen", []))
        expected = {a for a in actors if a != node_id}
        missing = sorted(expected - seen)
        all_seen &= not missing and entry.get("exit_code") == 0
        peers = summary.get("peers", {}).values()
        table[node_id] = {
            "exit_code": entry.get("exit_code"),
            "joined": summary.get("joined", False),
            "actors_seen": sorted(seen),
            "missing": missing,
            "latency_p50_ms": _worst(peers, "latency_p50_ms"),
            "latency_p99_ms": _worst(peers, "latency_p99_ms"),
            "despawns": summary.get("despawns", []),
            "npcs_now": summary.get("npcs_now", 0),
            "poses_sent": summary.get("poses_sent", 0),
        }
    tools = {c.name: c.proc.returncode for c in children if c.role == "tool"}
    ok = all(t["exit_code"] == 0 for t in table.values()) and all(v == 0 for v in tools.values())
    return {
        "ok": ok,
        "all_seen": all_seen,
        "nodes": table,
        "authority": authority,
        "observer": watched,
        "tools": tools,
    }


def _worst(peers: Any, field_name: str) -> float | None:
    values = [p.get(field_name) for p in peers if isinstance(p.get(field_name), float | int)]
    values = [v for v in values if not math.isnan(v)]
    return max(values) if values else None


def _print_summary(summary: dict[str, Any], as_json: bool) -> None:
    if as_json:
        print(json.dumps(summary, indent=2, sort_keys=True))
        return
    print(
        f"{'node':<14} {'joined':<7} {'saw':<5} {'NPCs':>5} {'p50 ms':>8} {'p99 ms':>8}  "
        "despawns  missing"
    )
    for node_id, row in summary["nodes"].items():
        p50, p99 = row["latency_p50_ms"], row["latency_p99_ms"]
        print(
            f"{node_id:<14} {row['joined']!s:<7} {len(row['actors_seen']):<5} {row['npcs_now']:>5} "
            f"{p50 if p50 is not None else '-':>8} {p99 if p99 is not None else '-':>8}  "
            f"{len(row['despawns']):<9} {' '.join(row['missing']) or '-'}"
        )
    tick = (summary.get("authority") or {}).get("tick") or {}
    if tick:
        print(
            f"authority: {tick.get('ticks')} ticks, p50 {tick.get('tick_p50_ms')} ms, "
            f"p99 {tick.get('tick_p99_ms')} ms"
        )
    print(
        "every node saw every other node"
        if summary["all_seen"]
        else "NOT every node saw every other node"
    )
