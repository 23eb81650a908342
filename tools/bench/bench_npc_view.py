"""Benchmark: what 1000 NPCs at 20 Hz cost a node's world view (issue 11, item 5).

    python tools/bench/bench_npc_view.py [--npcs 1000] [--batches 400] [--write]

The receive path is what a node does per `world/npc` sample: decode the `NpcBatch` payload
(the NodeClient callback), push it, and apply it in `WorldView.update` (kept as an array, no
object per NPC). The interpolation call is `WorldView.npc_frame(now)`: every NPC at the view's
render time, as arrays, in each render mode; `npc_views` (an object per NPC) is measured too
for comparison. CPU time (process_time) per call, over `--batches` batches of SUMO-like rows.
"""

from __future__ import annotations

import argparse
import sys
import time

import msgspec
import numpy as np
from benchdoc import RunInfo, command_line, write_section

from carlaverse import messages as m
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView

RATE_HZ = 20.0  # the authority's NPC batch rate
BUDGET = 0.02  # of a core, for receiving and interpolating


def batches(npcs: int, count: int) -> list[bytes]:
    rng = np.random.default_rng(1)
    ids = [f"veh{i}" for i in range(npcs)]
    x0, y0 = rng.uniform(-500, 500, npcs), rng.uniform(-500, 500, npcs)
    heading, speed = rng.uniform(-np.pi, np.pi, npcs), rng.uniform(0, 15, npcs)
    out = []
    for k in range(count):
        t = 1000.0 + k / RATE_HZ
        rows = np.zeros(npcs, dtype=m.NPC_DTYPE)
        rows["x"] = x0 + np.cos(heading) * speed * (t - 1000)
        rows["y"] = y0 + np.sin(heading) * speed * (t - 1000)
        rows["yaw"], rows["vx"], rows["vy"] = (
            heading,
            np.cos(heading) * speed,
            np.sin(heading) * speed,
        )
        rows["length"], rows["width"], rows["height"] = 4.5, 1.8, 1.5
        out.append(m.NPC_BATCH.encode(m.NpcBatch.pack(k, t, ids, rows)))
    return out


def measure(payloads: list[bytes], mode: str) -> dict[str, float]:
    world = WorldView("me", msgspec.structs.replace(InterpolationSettings(), render_mode=mode))
    receive = frame = views = 0.0
    for k, payload in enumerate(payloads):
        now = 1000.0 + k / RATE_HZ + 0.03
        c0 = time.process_time()
        world.intake.npc(m.NPC_BATCH.decode(payload), now)
        world.update(now)
        c1 = time.process_time()
        world.npc_frame(now + 0.001)
        c2 = time.process_time()
        if k % 10 == 0:
            sum(1 for _ in world.npc_views(now + 0.002))
        c3 = time.process_time()
        receive, frame, views = receive + c1 - c0, frame + c2 - c1, views + (c3 - c2) * 10
    n = len(payloads)
    return {"receive_ms": 1e3 * receive / n, "frame_ms": 1e3 * frame / n,
            "views_ms": 1e3 * views / n}  # fmt: skip


def body(npcs: int, n: int, results: dict[str, dict[str, float]]) -> str:
    lines = []
    for mode, r in results.items():
        share = (r["receive_ms"] + r["frame_ms"]) * 1e-3 * RATE_HZ
        lines.append(
            f"| {mode} | {r['receive_ms']:.3f} | {r['frame_ms']:.3f} | {share:.2%} "
            f"| {'yes' if share <= BUDGET else 'NO'} | {r['views_ms']:.2f} |"
        )
    return (
        f"{npcs} NPCs per batch at {RATE_HZ:g} Hz, {n} batches; CPU time per batch "
        "(process_time). Receive = decode + push + `WorldView.update` (the batch is kept as "
        "an array); frame = one `WorldView.npc_frame(now)` (every NPC interpolated at the "
        "view's render time, as arrays). Share = (receive + one frame per batch) × "
        f"{RATE_HZ:g} Hz, "
        f"budget {BUDGET:.0%} of a core. `npc_views` (an object per NPC, for comparison) is "
        "what a caller pays who asks one by one.\n\n"
        "| render mode | receive [ms] | frame [ms] | share of a core | within budget "
        "| npc_views [ms] |\n|---|---|---|---|---|---|\n" + "\n".join(lines)
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--npcs", type=int, default=1000)
    parser.add_argument("--batches", type=int, default=400)
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    payloads = batches(args.npcs, args.batches)
    results = {mode: measure(payloads, mode) for mode in ("present", "past")}
    text = body(args.npcs, args.batches, results)
    print(text)
    if args.write:
        write_section("NPCs in the world view", text, command_line(argv), run)
    shares = [(r["receive_ms"] + r["frame_ms"]) * 1e-3 * RATE_HZ for r in results.values()]
    return 0 if max(shares) <= BUDGET else 1


if __name__ == "__main__":
    sys.exit(main())
