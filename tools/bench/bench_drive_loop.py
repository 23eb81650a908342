"""Benchmark: CPU cost of one `DriveLoop.step` (the drive node's 1 kHz loop body), pure Python.

    python tools/bench/bench_drive_loop.py [--seconds 20] [--write]

For each shipped drive config it drives a scripted lap (launch, sinusoidal steering at
speed, a hard stop, turn signals and a cruise-control override) and times every step with
perf_counter_ns, then times the parts separately (controls, car physics, steering feel,
motion cueing) so a regression points at its module. The budget is 1 ms per step at 1 kHz;
the target is < 150 µs so the loop keeps most of its period for I/O and the OS.

This measures compute only. The loop's period error under load (with the fabric process
busy) belongs to the node runtime's benchmark. This is a measurement, not a test.
"""

from __future__ import annotations

import argparse
import gc
import math
import statistics
import sys
import time
from pathlib import Path

from benchdoc import RunInfo, command_line, write_section
from carlaverse_nodes.drive.config import load_drive_config
from carlaverse_nodes.drive.vehicle_loop import DriveLoop

from carlaverse.hal import InputState
from carlaverse.messages import Override
from carlaverse.support.stats import percentile

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ("drive-desktop", "drive-wheel", "drive-cabin")
DT = 0.001  # [s]
BUDGET_US = DT * 1e6  # [µs] one period at 1 kHz
STAGE_SPEED = 20.0  # [m/s] the stages are timed cruising at this speed
TARGET_US = 150.0  # [µs] leaves most of the period for I/O and the OS


def scripted_input(t: float, buttons: dict[str, bool]) -> InputState:
    """A lap: launch, weave at speed, brake hard at 12 s, indicator taps every 3 s."""
    throttle = 0.8 if t < 12.0 else 0.0
    brake = 1.0 if 12.0 <= t < 15.0 else 0.0
    steer = 0.15 * math.sin(0.8 * t) if t > 3.0 else 0.0
    tap = (t % 3.0) < 0.05
    for name in buttons:
        buttons[name] = tap and name.startswith(("indicator_left", "stalk_left", "hat"))
    axes = {"steer": steer, "throttle": throttle, "brake": brake, "clutch": 0.0}
    return InputState(t, axes, dict(buttons), {"dpad": (-1 if tap else 0, 0)})


def button_names(loop: DriveLoop) -> dict[str, bool]:
    sources = loop.config.controls.buttons.values()
    names = [s for v in sources for s in ([v] if isinstance(v, str) else v)]
    return dict.fromkeys((n for n in names if not n.startswith("hat:")), False)


def time_steps(config_name: str, seconds: float) -> list[int]:
    config, vehicle = load_drive_config(ROOT / "configs" / f"{config_name}.yaml")
    loop = DriveLoop(config, vehicle)
    loop.engage_drive()
    buttons = button_names(loop)
    samples = [scripted_input(i * DT, buttons) for i in range(round(seconds / DT))]
    costs = []
    clock = time.perf_counter_ns
    gc.collect()
    for i, sample in enumerate(samples):
        if i == len(samples) // 2:
            loop.submit_override(Override(1, 0.0, "bench-acc", cruise_speed_mps=20.0))
        start = clock()
        loop.step(DT, sample)
        costs.append(clock() - start)
    return costs


def time_parts(seconds: float) -> dict[str, float]:
    """Mean cost [µs] of each stage, run in isolation on the desktop config."""
    config, vehicle = load_drive_config(ROOT / "configs" / "drive-desktop.yaml")
    loop = DriveLoop(config, vehicle)
    loop.place(0.0, 0.0, 0.0, STAGE_SPEED)
    loop.engage_drive()
    n = round(seconds / DT)
    sample = InputState(0.0, {"steer": 0.1, "throttle": 0.5, "brake": 0.0}, {})
    s, pt = loop.car.state, loop.car.powertrain
    stages = {
        "controls.read": lambda: loop.controls.read(sample),
        "car.step (powertrain + chassis)": lambda: loop.car.step(DT, 0.1, 0.5, 0.0),
        "vertical.step (road profile + suspension)": lambda: loop.vertical.step(
            DT, s.x, s.y, s.yaw, s.vx
        ),
        "steering_feel.update": lambda: loop.steering_feel.update(
            DT, s.vx, s.alpha_front, s.fz_front, pt.rpm, 3.0, 0.0
        ),
        "motion_cueing.update": lambda: loop.motion_cueing.update(
            DT, s.ax, s.ay, 0.2, s.vx, 0.0, 0.1, pt.rpm, pt.engine_torque_nm, 0.001
        ),
        "DriveLoop.step (all)": lambda: loop.step(DT, sample),
    }
    result = {}
    for name, fn in stages.items():
        start = time.perf_counter_ns()
        for _ in range(n):
            fn()
        result[name] = (time.perf_counter_ns() - start) / n / 1000.0
    return result


def pct(values: list[int], q: float) -> float:
    """The q-quantile of `values` [ns] in µs."""
    return percentile(values, q) / 1000.0


def report(seconds: float) -> str:
    rows = [
        "| config | steps | mean µs | p50 µs | p99 µs | p99.9 µs | max µs |",
        "|---|---|---|---|---|---|---|",
    ]
    tails = []
    for name in CONFIGS:
        costs = time_steps(name, seconds)
        rows.append(
            f"| {name} | {len(costs)} | {statistics.fmean(costs) / 1000:.1f} | "
            f"{pct(costs, 0.5):.1f} | {pct(costs, 0.99):.1f} | {pct(costs, 0.999):.1f} | "
            f"{max(costs) / 1000:.1f} |"
        )
        tails.append((pct(costs, 0.99) / pct(costs, 0.5), pct(costs, 0.999) / pct(costs, 0.5)))
    rows += ["", f"| stage (desktop config, {STAGE_SPEED:g} m/s) | mean µs |", "|---|---|"]
    rows += [f"| {k} | {v:.1f} |" for k, v in time_parts(min(seconds, 5.0)).items()]
    return (
        "One `DriveLoop.step` (controls → lights/indicators/gears → ADAS → impulses → car "
        "physics and vertical motion over the road → steering feel → motion cueing) over a "
        "scripted lap at 1 kHz, in this "
        f"process. Budget {BUDGET_US:.0f} µs, target < {TARGET_US:.0f} µs.\n\n"
        + "\n".join(rows)
        + "\n\n"
        + reading(max(t[0] for t in tails), max(t[1] for t in tails))
    )


PREEMPTED = 5.0  # a percentile this many times the median is not the step's own work


def reading(p99_ratio: float, p999_ratio: float) -> str:
    """What the tail says, from this run's own ratios to the median."""
    text = "The step's own cost is the p50 column and the stage table. "
    if p999_ratio < PREEMPTED:
        return text + f"Even the p99.9 stays within {PREEMPTED:g} × the p50: no preemption showed."
    worst = "p99" if p99_ratio >= PREEMPTED else "p99.9"
    return text + (
        f"From the {worst} on (up to {max(p99_ratio, p999_ratio):.0f} × the p50) the tail is the "
        "OS preempting this process for others on the same cores, not compute: the node runtime "
        "should give the loop process a core of its own or a real-time priority (the drive "
        "node's loop asks for one) to keep such tails out of the loop's period error."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated lap length [s]")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    body = report(args.seconds)
    print(body)
    if args.write:
        write_section("Drive loop step cost", body, command_line(argv), run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
