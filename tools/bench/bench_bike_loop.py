"""Benchmark: period error of the bike node's 200 Hz loop, alone and with 32 peers on the fabric.

    python tools/bench/bench_bike_loop.py [--duration 20] [--rate 200] [--write]

Runs a router, an authority and `carlaverse join bike --backend sim` (the simulated FTMS
trainer, a scripted rider, fork FFB recorded) as processes; the second run adds 32 scripted
peers publishing at 50 Hz (the drive benchmark's peer processes and harness), so the bike's
fabric process receives 1600 poses/s while its loop process keeps time. The loop reports its
own period error (actual wake-up minus deadline). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from bench_drive_timing import PEER_LOADS, PEER_RATE_HZ
from bench_drive_timing import run as run_node
from benchdoc import RunInfo, command_line, write_section

TARGET_P99_MS = 0.5  # [ms] period error p99 of the bike loop


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=20.0, help="bike node run [s]")
    parser.add_argument("--rate", type=float, default=200.0, help="loop rate [Hz], >= 200")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    lines = [
        "| fabric load | loop Hz | ticks | period error p50 ms | p99 ms | max ms | peers seen "
        "| 1-min load after the run |",
        "|---|---|---|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "bike.yaml"
        config.write_text(f"loop: {{rate_hz: {args.rate}}}\n")
        for n in PEER_LOADS:
            r = run_node(args.duration, n, ["--config", str(config)], kind="bike")
            label = "loop alone" if n == 0 else f"{n} scripted peers at {PEER_RATE_HZ:g} Hz"
            lines.append(
                f"| {label} | {r['rate_hz']:.0f} | {r['ticks']} | {r['period_error_p50_ms']:.4f} "
                f"| {r['period_error_p99_ms']:.4f} | {r['period_error_max_ms']:.3f} "
                f"| {r['peers_seen']} | {os.getloadavg()[0]:.1f} |"
            )
            print(lines[-1], flush=True)
    lines += ["", f"Target: period error p99 ≤ {TARGET_P99_MS:g} ms."]
    if args.write:
        write_section("Bike loop timing", "\n".join(lines), command_line(argv), run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
