"""Benchmark: what a drive node's own view costs per frame, how late it shows the loop's motion,
and whether it disturbs the loop.

    python tools/bench/bench_view_latency.py [--duration 15] [--rounds 2] [--write]

Runs a router, an authority (the town scenario) and `carlaverse join drive --backend sim` as
processes, in rounds: once the node alone, once with `--view --offscreen --view-out DIR` at
960×540 on the cpu quality, the order alternating per round so a drift of the machine's load
weighs on both. The view reports its frame in parts (draw, read-back, PNG write) and its
motion-to-photon: from the loop's stamp on the state it drew (host monotonic clock) to the
end of that frame's read-back. The loop reports its own period error. A measurement, not a
test.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from bench_drive_timing import run as run_drive
from benchdoc import RunInfo, command_line, write_section

WIDTH, HEIGHT = 960, 540
QUALITY = "cpu"
MAX_FPS = 60
SCENARIO = "town"
WRITE_EVERY_S = 0.5  # [s] the CLI's default --view-every
RIG = """output: offscreen
camera: {mode: simple, resolution: {width: %d, height: %d}, fov_deg: 90, head: {z: 1.2}}
max_fps: %d
quality: %s
"""
ALONE, VIEWED = "loop alone", "with its view"


def rounds(duration_s: float, count: int, tmp: Path) -> list[tuple[str, dict]]:
    """(label, the loop's summary with its view's under 'view') per run, interleaved."""
    rig = tmp / "rig.yaml"
    rig.write_text(RIG % (WIDTH, HEIGHT, MAX_FPS, QUALITY))
    results = []
    for i in range(count):
        order = (ALONE, VIEWED) if i % 2 == 0 else (VIEWED, ALONE)
        for label in order:
            flags: list[str] = []
            if label == VIEWED:
                flags = ["--view", "--offscreen", "--render-config", str(rig),
                         "--view-out", str(tmp / f"frames-{i}"),
                         "--view-every", str(WRITE_EVERY_S)]  # fmt: skip
            results.append((label, run_drive(duration_s, 0, flags, scenario=SCENARIO)))
            print(row(i + 1, *results[-1]), flush=True)
    return results


def row(round_no: int, label: str, r: dict) -> str:
    loop = (f"{r['ticks']} | {r['period_error_p50_ms']:.4f} | {r['period_error_p99_ms']:.4f} | "
            f"{r['period_error_max_ms']:.3f}")  # fmt: skip
    v = r.get("view")
    if not v:
        return f"| {round_no} | {label} | {loop} | – | – | – | – | – | – |"
    if v.get("error"):
        raise RuntimeError(f"the view failed: {v['error']}")

    def pair(name: str) -> str:
        return f"{v[name + '_p50']:.1f} / {v[name + '_p99']:.1f}"

    parts = " | ".join(pair(n) for n in ("draw_ms", "readback_ms", "write_ms"))
    return (f"| {round_no} | {label} | {loop} | {v['frames']} | {v['fps']:.1f} | {parts} | "
            f"{pair('motion_to_photon_ms')} |")  # fmt: skip


HEADER = [
    "| round | drive node | ticks | loop period error p50 [ms] | p99 [ms] | max [ms] | "
    "view frames | view fps | draw p50 / p99 [ms] | read-back p50 / p99 [ms] | "
    "PNG write p50 / p99 [ms] | motion-to-photon p50 / p99 [ms] |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|",
]


def notes(duration_s: float, load_1min: float) -> str:
    return (
        f"`carlaverse join drive --backend sim` for {duration_s:g} s per run in the "
        f"{SCENARIO} scenario beside a router and an authority, alone and with "
        f"`--view --offscreen --view-out DIR` ({WIDTH}×{HEIGHT}, quality `{QUALITY}`, capped "
        f"at {MAX_FPS} fps, a PNG every {WRITE_EVERY_S:g} s), the two interleaved. View fps "
        "counts the whole frame: draw (the world's state read, the scene updated and "
        "rendered), read-back (the image from the GL renderer to RAM, every frame: offscreen "
        "it is the view's output) and the PNG write on frames that write one (its p50 / p99 "
        "are over those frames only). Motion-to-photon runs from the loop's monotonic stamp "
        "on the state a frame drew to the end of that frame's read-back, over every frame "
        "drawn from a state not drawn before. The GL renderer is llvmpipe on the machine's "
        "CPUs, which the loop, the fabric processes and the view share: "
        f"the 1-minute load was {load_1min:.1f} on {os.cpu_count()} cores when the run started, "
        "with other work running beside it, so these figures are upper bounds of what this "
        "code costs."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=15.0, help="[s] per drive run")
    parser.add_argument("--rounds", type=int, default=2, help="rounds of (alone, with view)")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run_info = RunInfo.start()
    print("\n".join(HEADER), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        results = rounds(args.duration, args.rounds, Path(tmp))
    lines = [row(i // 2 + 1, label, r) for i, (label, r) in enumerate(results)]
    body = "\n".join([notes(args.duration, run_info.load_1min), "", *HEADER, *lines])
    if args.write:
        write_section("Drive view latency", body, command_line(argv), run_info)
    return 0


if __name__ == "__main__":
    sys.exit(main())
