"""Benchmark: every remote-actor renderer over emulated WAN links, against the same references.

    python tools/bench/bench_wan.py [--live-seconds 10] [--write]

Two parts, both measuring the three renderers of `carlaverse.testing.render_metrics` (world view
in past mode, in present mode, naive) with the same four figures (error vs truth at the time
shown, error vs truth now, lag, largest frame-to-frame jump beyond the true motion):

1. *Simulation* (the full grid, deterministic, seeded, seconds of CPU): a 50 Hz pose stream
   along four bounded-jerk paths at 14 m/s (`carlaverse.testing.trajectories`) through the
   real wire codec and a `LinkModel` (0/10/25/50/100 ms one way, ± 0/10 ms jitter, 0/1/5 %
   loss, as TCP — retransmission after the RTO, head-of-line blocking — and as datagrams —
   drops), drawn at 100 Hz (`carlaverse.testing.stream_sim`). Clocks are perfect.
2. *Live* (a subset, real processes on 127.0.0.1, no root): a router, the authority and a
   scripted bike on a circle (r = 20 m, 14 m/s) whose only route is a `LinkEmulator` TCP relay,
   observed by `tools/wan/wan_probe.py` through real Zenoh with real clock sync; the relay is
   re-profiled for each row.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchdoc import RunInfo, command_line, write_section

from carlaverse.procs import Child, free_port, start, stop_children
from carlaverse.testing.linkemu import LinkProfile
from carlaverse.testing.render_metrics import RENDERERS, Metrics
from carlaverse.testing.stream_sim import SimRun, simulate
from carlaverse.testing.trajectories import PATHS

ROOT = Path(__file__).resolve().parents[2]
DELAYS_MS = (0, 10, 25, 50, 100)
JITTERS_MS = (0, 10)
LOSSES = (0.0, 0.01, 0.05)
TARGET = (25, 10, 0.01)  # the target link: 25 ± 10 ms, 1 % loss
TARGET_NOW_P95_M, TARGET_JUMP_M = 0.25, 0.2
LIVE_ROWS = ((25, 10, 0.0), (25, 10, 0.01), (100, 10, 0.01))
READY_TIMEOUT_S = 60.0  # [s] for the probe to draw the bike (it prints `ready`)
REPORT_TIMEOUT_S = 60.0  # [s] for the probe to print its report after SIGINT


def links() -> list[tuple[int, int, float]]:
    return [(d, j, loss) for d in DELAYS_MS for j in JITTERS_MS if j <= d for loss in LOSSES]


def simulate_grid(run: SimRun) -> dict[tuple[Any, ...], dict[str, Metrics]]:
    """(transport, path, delay, jitter, loss) -> metrics per renderer."""
    paths = {name: make(run.duration_s + 1.0) for name, make in PATHS.items()}
    out = {}
    for transport in ("tcp", "datagram"):
        for seed, (d, j, loss) in enumerate(links()):
            profile = LinkProfile(d / 1e3, j / 1e3, loss)
            for name, path in paths.items():
                out[transport, name, d, j, loss] = simulate(path, profile, transport, seed, run)[0]
    return out


def worst(grid: dict, transport: str, link: tuple, renderer: str, field: str) -> float:  # type: ignore[type-arg]
    return max(getattr(grid[(transport, p, *link)][renderer], field) for p in PATHS)


def target_table(grid: dict) -> str:  # type: ignore[type-arg]
    head = (
        "| path | renderer | error vs now p50 / p95 / max [m] | error at time shown p95 [m] "
        "| lag [ms] | largest jump beyond true motion [m] |\n|---|---|---|---|---|---|\n"
    )
    lines = []
    for path in PATHS:
        for r in RENDERERS:
            x = grid[("tcp", path, *TARGET)][r]
            lines.append(f"| {path} | {r} | {x.now_p50_m:.3f} / {x.now_p95_m:.3f} / "
                         f"{x.now_max_m:.3f} | {x.shown_p95_m:.3f} | {x.lag_mean_ms:.0f} "
                         f"| {x.jump_max_m:.3f} |")  # fmt: skip
    return head + "\n".join(lines)


def grid_table(grid: dict, transport: str) -> str:  # type: ignore[type-arg]
    head = "| one way | jitter ± | loss |" + "".join(
        f" {r}: vs now p95 / jump [m] |" for r in RENDERERS
    ) + " past lag [ms] |\n|---|---|---|---|---|---|---|\n"  # fmt: skip
    lines = []
    for link in links():
        d, j, loss = link
        cells = "".join(
            f" {worst(grid, transport, link, r, 'now_p95_m'):.3f} / "
            f"{worst(grid, transport, link, r, 'jump_max_m'):.3f} |"
            for r in RENDERERS
        )
        lag = worst(grid, transport, link, "past", "lag_mean_ms")
        lines.append(f"| {d} ms | {j} ms | {loss:.0%} |{cells} {lag:.0f} |")
    return head + "\n".join(lines)


def verdict(grid: dict) -> tuple[bool, float, float]:  # type: ignore[type-arg]
    p95 = worst(grid, "tcp", TARGET, "present", "now_p95_m")
    jump = worst(grid, "tcp", TARGET, "present", "jump_max_m")
    return p95 <= TARGET_NOW_P95_M and jump <= TARGET_JUMP_M, p95, jump


# ---------------------------------------------------------------- live subset


def run_live(seconds: float, workdir: Path) -> list[tuple[tuple[int, int, float], dict]]:  # type: ignore[type-arg]
    from carlaverse_nodes.scripted.trajectories import CirclePath

    from carlaverse.testing.linkemu import LinkEmulator
    from carlaverse.testing.render_metrics import probe_metrics, window

    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    children = [_spawn(["-m", "carlaverse", "router", "--listen", endpoint])]
    link = LinkEmulator(("127.0.0.1", 0), ("127.0.0.1", port), LinkProfile()).start()
    try:
        children.append(_spawn(["-m", "carlaverse", "authority", "--scenario", "none",
                                "--session", "bench", "--connect", endpoint]))  # fmt: skip
        path = {"type": "circle", "radius": 20.0, "speed_mps": 14.0}
        config = workdir / "bike.yaml"
        relay = f"tcp/127.0.0.1:{link.address[1]}"
        config.write_text(
            "node: {node_id: bike, session: bench, kind: scripted, actor_kind: bicycle}\n"
            f"fabric: {{mode: client, connect: ['{relay}']}}\npath: {path}\n"
        )
        children.append(_spawn(["-m", "carlaverse", "join", "scripted", "--config", str(config)]))
        probe = _spawn([str(ROOT / "tools/wan/wan_probe.py"), "--id", "probe", "--session",
                        "bench", "--connect", endpoint, "--duration", "3600",
                        "--target", f"bike={config}"])  # fmt: skip
        children.append(probe)
        probe.wait_for_line(lambda line: line.strip() == "ready", READY_TIMEOUT_S)
        windows = []
        for d, j, loss in LIVE_ROWS:
            link.set_profile(LinkProfile(d / 1e3, j / 1e3, loss))
            start = time.monotonic() + 3.0  # the delay estimate and clock settle
            time.sleep(3.0 + seconds)  # the row is a fixed-length experiment
            windows.append(((d, j, loss), start, start + seconds))
            print(f"live {d} ± {j} ms, {loss:.0%}", file=sys.stderr, flush=True)
        stop_children([probe], grace_s=REPORT_TIMEOUT_S)  # it prints its report on SIGINT
        report = probe.json()
    finally:
        for child in reversed(children):
            stop_children([child])
        link.close()
    circle = CirclePath(radius=20.0, speed_mps=14.0)
    return [(row, probe_metrics(window(report, "bike", a, b), circle)) for row, a, b in windows]


def _spawn(args: list[str]) -> Child:
    """`python ARGS…` as a child (`carlaverse.procs`): its own group, both streams drained."""
    name = args[2] if args[0] == "-m" else Path(args[0]).stem
    return start(args, name=name, command=[sys.executable])


def live_table(rows: list) -> str:  # type: ignore[type-arg]
    head = ("| one way | jitter ± | loss | renderer | frames | error vs now p95 / max [m] "
            "| error at time shown p95 [m] | lag [ms] | largest jump [m] |\n"
            "|---|---|---|---|---|---|---|---|---|\n")  # fmt: skip
    lines = []
    for (d, j, loss), by in rows:
        for r in RENDERERS:
            x = by[r]
            lines.append(f"| {d} ms | {j} ms | {loss:.0%} | {r} | {x.frames} | "
                         f"{x.now_p95_m:.3f} / {x.now_max_m:.3f} | {x.shown_p95_m:.3f} | "
                         f"{x.lag_mean_ms:.0f} | {x.jump_max_m:.3f} |")  # fmt: skip
    return head + "\n".join(lines)


def body(grid: dict, live: list, run: SimRun, live_s: float) -> str:  # type: ignore[type-arg]
    ok, p95, jump = verdict(grid)
    return (
        "Every renderer against the same references: **error vs now** (where the actor is "
        "drawn vs where it is — what a human sees), **error at the time shown**, **lag** "
        "(now − time shown) and the **largest frame-to-frame jump beyond the true motion** "
        "at 100 Hz. Renderers: `past` (world view, past mode: interpolated at now − delay), "
        "`present` (world view, present mode: newest sample projected to now, corrections "
        "blended projectively), `naive` (newest sample as is). Poses at 50 Hz, 14 m/s.\n\n"
        f"### Simulation, target link (25 ± 10 ms, 1 % loss, TCP)\n\n"
        f"In-process, deterministic (seeded), {run.duration_s:g} s per run of which the first "
        f"{run.warmup_s:g} s are not measured; real wire codec; clocks perfect. "
        f"Target: present p95 error vs now ≤ {TARGET_NOW_P95_M} m, no jump above "
        f"{TARGET_JUMP_M} m → worst path p95 {p95:.3f} m, jump {jump:.3f} m: "
        f"**{'met' if ok else 'NOT met'}**.\n\n"
        + target_table(grid)
        + "\n\n### Simulation, full grid (worst of the four paths per cell)\n\n"
        "TCP: a lost segment is retransmitted after RTO = max(200 ms, SRTT + 4·RTTVAR) and "
        "holds everything behind it (see `carlaverse/testing/linkemu.py`).\n\n"
        + grid_table(grid, "tcp")
        + "\n\nDatagrams (UDP/QUIC datagram transport): a lost sample is simply gone.\n\n"
        + grid_table(grid, "datagram")
        + f"\n\n### Live subset (real Zenoh, real clock sync, `LinkEmulator` on 127.0.0.1)\n\n"
        f"A scripted bike on a circle (r = 20 m) behind the relay, {live_s:g} s per row after "
        "3 s settling; the error includes the clock-sync error.\n\n"
        + live_table(live)
        + "\n\n**Default render mode: `present`.** Measured against where actors are now, "
        "past mode is behind by speed × delay (its delay must cover latency, jitter and, over "
        "TCP, retransmission stalls), which at 14 m/s is metres; present mode stays within "
        "centimetres on every bounded-jerk path, and its blending keeps every frame-to-frame "
        "jump small, where naive leaps by metres after a stall. Past mode stays available per "
        "node (`interpolation.render_mode: past`) for replay-like uses where the exact past "
        "matters more than the present."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--live-seconds", type=float, default=10.0, help="measured s per row")
    parser.add_argument("--no-live", action="store_true", help="simulation only")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    measured = RunInfo.start()
    run = SimRun()
    started = time.process_time()
    grid = simulate_grid(run)
    print(f"simulated {len(grid)} runs in {time.process_time() - started:.0f} s CPU",
          file=sys.stderr)  # fmt: skip
    live = []
    if not args.no_live:
        with tempfile.TemporaryDirectory(prefix="bench-wan-") as tmp:
            live = run_live(args.live_seconds, Path(tmp))
    text = body(grid, live, run, args.live_seconds)
    print(text)
    if args.write:
        write_section("WAN", text, command_line(argv), measured)
    return 0 if verdict(grid)[0] and not math.isnan(verdict(grid)[1]) else 1


if __name__ == "__main__":
    sys.exit(main())
