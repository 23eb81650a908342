"""Benchmark: period error of the bike node's 200 Hz loop, alone and with 32 peers on the fabric.

    python tools/bench/bench_bike_loop.py [--duration 20] [--rate 200] [--write]

Runs a router, an authority and `carlaverse join bike --backend sim` (the simulated FTMS
trainer, a scripted rider, fork FFB recorded) as processes; the second run adds 32 scripted
peers publishing at 50 Hz (the drive benchmark's peer processes), so the bike's fabric process
receives 1600 poses/s while its loop process keeps time. The loop reports its own period error
(actual wake-up minus deadline). A measurement, not a test; target p99 ≤ 0.5 ms.
"""

from __future__ import annotations

import argparse
import json
import logging
import multiprocessing as mp
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_drive_timing import peers
from bench_fabric import _port
from benchdoc import write_section


def quiet_peers(endpoint: str, first: int, count: int, stop: mp.synchronize.Event) -> None:
    """The drive benchmark's peers, without their warnings when a loaded host slows queries."""
    logging.disable(logging.WARNING)
    peers(endpoint, first, count, stop)


def run(duration: float, n_peers: int, config: Path) -> dict:
    endpoint = f"tcp/127.0.0.1:{_port()}"
    cli = [sys.executable, "-m", "carlaverse"]
    router = subprocess.Popen([*cli, "router", "--listen", endpoint], stdout=subprocess.DEVNULL)
    authority = subprocess.Popen(
        [*cli, "authority", "--scenario", "none", "--session", "bench", "--connect", endpoint],
        stderr=subprocess.DEVNULL,
    )
    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    groups = range(n_peers // 8)
    workers = [ctx.Process(target=quiet_peers, args=(endpoint, k * 8, 8, stop)) for k in groups]
    for w in workers:
        w.start()
    time.sleep(2.0 if workers else 0.5)
    bike = subprocess.run(
        [*cli, "join", "bike", "--id", "bike-1", "--session", "bench", "--connect", endpoint,
         "--config", str(config), "--backend", "sim", "--duration", str(duration), "--json"],
        capture_output=True, text=True,
    )  # fmt: skip
    stop.set()
    for w in workers:
        w.join(10)
        if w.is_alive():  # a zenoh close that timed out on a loaded host: do not hang here
            w.terminate()
    for p in (authority, router):
        p.terminate()
        p.wait(10)
    summary = json.loads(bike.stdout)
    loop = summary["extra"]["loop"]
    loop["peers_seen"] = len(summary["actors_seen"])
    loop["load"] = os.getloadavg()[0]  # the host's 1-min load: the figures depend on it
    return loop


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--rate", type=float, default=200.0, help="loop rate [Hz], >= 200")
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    lines = [
        "| fabric load | loop Hz | ticks | period error p50 ms | p99 ms | max ms | peers seen "
        "| host load (1 min, 2 cores) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "bike.yaml"
        config.write_text(f"loop: {{rate_hz: {args.rate}}}\n")
        for n in (0, 32):
            r = run(args.duration, n, config)
            label = "loop alone" if n == 0 else f"{n} scripted peers at 50 Hz"
            lines.append(
                f"| {label} | {r['rate_hz']:.0f} | {r['ticks']} | {r['period_error_p50_ms']:.4f} | "
                f"{r['period_error_p99_ms']:.4f} | {r['period_error_max_ms']:.3f} | "
                f"{r['peers_seen']} | {r['load']:.1f} |"
            )
            print(lines[-1], flush=True)
    if args.write:
        command = f"python tools/bench/bench_bike_loop.py --duration {args.duration:g}"
        write_section("Bike loop timing", "\n".join(lines), command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
