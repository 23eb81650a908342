"""Benchmark: period error of the drive node's 1 kHz loop, alone and with 32 peers on the fabric.

    python tools/bench/bench_drive_timing.py [--duration 20] [--write]

Runs a router, an authority and `carlaverse join drive --backend sim` as processes; the
second run adds 32 scripted peers publishing at 50 Hz (4 processes × 8 sessions), so the
drive node's fabric process receives 1600 poses/s while its loop process keeps time.
The loop reports its own period error (actual wake-up minus deadline). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing as mp
import sys
import time
from collections.abc import Sequence

from benchdoc import RunInfo, command_line, write_section

from carlaverse import procs

PEER_LOADS = (0, 32)  # scripted peers on the fabric, in processes of PEERS_PER_PROCESS
PEERS_PER_PROCESS = 8
PEER_RATE_HZ = 50.0  # [Hz] the scripted peers' pose rate


def peers(endpoint: str, first: int, count: int, stop: mp.synchronize.Event) -> None:
    """Scripted peers in one process; quiet, since a loaded host makes their queries slow."""
    logging.disable(logging.WARNING)
    from carlaverse_nodes.scripted.trajectories import CirclePath

    from carlaverse.transport.clock import MonotonicClock
    from carlaverse.transport.node_client import NodeClient, NodeSettings
    from carlaverse.transport.session import FabricSettings, open_session

    clients = []
    for i in range(first, first + count):
        session = open_session(FabricSettings(connect=[endpoint]))
        settings = NodeSettings(node_id=f"peer-{i}", session="bench", pose_rate_hz=PEER_RATE_HZ)
        client = NodeClient(session, settings, MonotonicClock())
        path = CirclePath(radius=20.0 + i, phase_deg=11.0 * i)
        clients.append((client.start(pose_source=path.pose_at), session))
    while not stop.is_set():
        for client, _ in clients:
            client.update()
        stop.wait(0.05)  # apply what arrived at 20 Hz, as a light node would
    for client, session in clients:
        client.close()
        session.close()


def run(
    duration: float,
    n_peers: int,
    node_args: Sequence[str] = (),
    scenario: str = "none",
    kind: str = "drive",
) -> dict:
    """A node's loop timing summary (and its view's, when `node_args` ask for one)."""
    endpoint = f"tcp/127.0.0.1:{procs.free_port()}"
    router = procs.start(["router", "--listen", endpoint], name="router")
    authority = procs.start(
        ["authority", "--scenario", scenario, "--session", "bench", "--connect", endpoint],
        name="authority",
    )
    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    workers = [
        ctx.Process(target=peers, args=(endpoint, k * PEERS_PER_PROCESS, PEERS_PER_PROCESS, stop))
        for k in range(n_peers // PEERS_PER_PROCESS)
    ]
    for w in workers:
        w.start()
    time.sleep(2.0 if workers else 0.5)
    node = procs.start(
        ["join", kind, "--id", f"{kind}-1", "--session", "bench", "--connect", endpoint,
         "--backend", "sim", "--duration", str(duration), "--json", *node_args],
        name=f"{kind} node",
    )  # fmt: skip
    node.proc.wait()
    stop.set()
    for w in workers:
        w.join(10)
        if w.is_alive():  # a Zenoh close that hangs on a loaded machine must not hang us
            w.terminate()
    procs.stop_children([authority])  # the authority before the router that carries it
    procs.stop_children([router])
    summary = node.json()
    if node.exit_code != 0 or summary is None:
        tail = "\n".join(node.err.lines()[-40:])
        raise RuntimeError(f"the {kind} node failed (exit {node.exit_code}):\n{tail}")
    loop = summary["extra"]["loop"]
    loop["peers_seen"] = len(summary["actors_seen"])
    if "view" in summary["extra"]:
        loop["view"] = summary["extra"]["view"]
    return loop


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=20.0, help="drive node run [s]")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run_info = RunInfo.start()
    lines = [
        "| fabric load | ticks | period error p50 ms | p99 ms | max ms | peers seen |",
        "|---|---|---|---|---|---|",
    ]
    for n in PEER_LOADS:
        r = run(args.duration, n)
        label = "loop alone" if n == 0 else f"{n} scripted peers at {PEER_RATE_HZ:g} Hz"
        lines.append(
            f"| {label} | {r['ticks']} | {r['period_error_p50_ms']:.4f} | "
            f"{r['period_error_p99_ms']:.4f} | {r['period_error_max_ms']:.3f} | "
            f"{r['peers_seen']} |"
        )
        print(lines[-1], flush=True)
    text = "\n".join([_intro(args.duration), "", *lines])
    if args.write:
        write_section("Drive loop timing", text, command_line(argv), run_info)
    return 0


def _intro(duration_s: float) -> str:
    return (
        "`carlaverse join drive --backend sim` for "
        f"{duration_s:g} s beside a router and an authority (each its own process); the loaded "
        "run adds scripted peers publishing poses, so the drive node's fabric process receives "
        "them all while its loop process keeps time. Period error = actual wake-up minus "
        "deadline, as the loop process reports it."
    )


if __name__ == "__main__":
    sys.exit(main())
