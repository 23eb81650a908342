"""Benchmark: period error of the drive node's 1 kHz loop, alone and with 32 peers on the fabric.

    python tools/bench/bench_drive_timing.py [--duration 20] [--write]

Runs a router, an authority and `carlaverse join drive --backend sim` as processes; the
second run adds 32 scripted peers publishing at 50 Hz (4 processes × 8 sessions), so the
drive node's fabric process receives 1600 poses/s while its loop process keeps time.
The loop reports its own period error (actual wake-up minus deadline). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fabric import _port
from benchdoc import write_section


def peers(endpoint: str, first: int, count: int, stop: mp.synchronize.Event) -> None:
    from carlaverse.fabric.clock import MonotonicClock
    from carlaverse.fabric.node_client import NodeClient, NodeSettings
    from carlaverse.fabric.session import FabricSettings, open_session
    from carlaverse.paths import CirclePath

    clients = []
    for i in range(first, first + count):
        session = open_session(FabricSettings(connect=[endpoint]))
        client = NodeClient(
            session, NodeSettings(node_id=f"peer-{i}", session="bench"), MonotonicClock()
        )
        path = CirclePath(radius=20.0 + i, phase_deg=11.0 * i)
        clients.append((client.start(pose_source=path.pose_at), session))
    while not stop.is_set():
        for client, _ in clients:
            client.update()
        stop.wait(0.05)
    for client, session in clients:
        client.close()
        session.close()


def run(
    duration: float, n_peers: int, drive_args: Sequence[str] = (), scenario: str = "none"
) -> dict:
    """The loop's timing summary (and the view's, when `drive_args` ask for one)."""
    endpoint = f"tcp/127.0.0.1:{_port()}"
    cli = [sys.executable, "-m", "carlaverse"]
    router = subprocess.Popen([*cli, "router", "--listen", endpoint], stdout=subprocess.DEVNULL)
    authority = subprocess.Popen(
        [*cli, "authority", "--scenario", scenario, "--session", "bench", "--connect", endpoint],
        stderr=subprocess.DEVNULL,
    )
    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    workers = [
        ctx.Process(target=peers, args=(endpoint, k * 8, 8, stop)) for k in range(n_peers // 8)
    ]
    for w in workers:
        w.start()
    time.sleep(2.0 if workers else 0.5)
    drive = subprocess.run(
        [
            *cli,
            "join",
            "drive",
            "--id",
            "drive-1",
            "--session",
            "bench",
            "--connect",
            endpoint,
            "--backend",
            "sim",
            "--duration",
            str(duration),
            "--json",
            *drive_args,
        ],
        capture_output=True,
        text=True,
    )
    stop.set()
    for w in workers:
        w.join(10)
    for p in (authority, router):
        p.terminate()
        p.wait(10)
    summary = json.loads(drive.stdout)
    loop = summary["extra"]["loop"]
    loop["peers_seen"] = len(summary["actors_seen"])
    if "view" in summary["extra"]:
        loop["view"] = summary["extra"]["view"]
    return loop


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    lines = [
        "| fabric load | ticks | period error p50 ms | p99 ms | max ms | peers seen |",
        "|---|---|---|---|---|---|",
    ]
    for n in (0, 32):
        r = run(args.duration, n)
        label = "loop alone" if n == 0 else f"{n} scripted peers at 50 Hz"
        lines.append(
            f"| {label} | {r['ticks']} | {r['period_error_p50_ms']:.4f} | "
            f"{r['period_error_p99_ms']:.4f} | {r['period_error_max_ms']:.3f} | "
            f"{r['peers_seen']} |"
        )
        print(lines[-1], flush=True)
    text = "\n".join(lines)
    if args.write:
        write_section("Drive loop timing", text, "python tools/bench/bench_drive_timing.py")
    return 0


if __name__ == "__main__":
    sys.exit(main())
