"""Benchmark: what dead reckoning costs the places that use it (issue 40, item 6).

    python tools/bench/bench_dead_reckoning.py [--egos 256] [--npcs 1000] [--repeats 7]

In-process, through each user's own entry point, never the motion model alone:

- the authority's tick: `egos_at` over `--egos` egos whose last samples turn and accelerate;
- the traffic engine's frame between steps: `NpcFrame.at` over `--npcs` NPC rows;
- a node's world view: `NpcTable.frame` past its newest batch (every NPC extrapolated), and
  `RemoteActor.present` / `RemoteActor.past` beyond the newest sample, once per ego.

Each figure is the best of `--repeats` short rounds of the mean CPU time per call (process time:
on a shared machine, time spent waiting for a core is not counted, and the best round is the
one least disturbed), in microseconds.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable

import numpy as np

from carlaverse import messages as m
from carlaverse.authority.actors import egos_at
from carlaverse.authority.domain import EgoTrack
from carlaverse.traffic.engine import NpcFrame
from carlaverse.world.npc_table import NpcTable
from carlaverse.world.remote_actor import InterpolationSettings, RemoteActor

T = 100.0  # [s] session time of the newest samples


def turning_pose(rng: np.random.Generator, t: float) -> m.Pose:
    """A sample of an actor on a curve, speeding up: every term of the model is exercised."""
    yaw, speed, yaw_rate = rng.uniform(-math.pi, math.pi), rng.uniform(1, 20), rng.uniform(-1, 1)
    vx, vy = speed * math.cos(yaw), speed * math.sin(yaw)
    ax, ay = -yaw_rate * vy + 0.5 * math.cos(yaw), yaw_rate * vx + 0.5 * math.sin(yaw)
    x, y = rng.uniform(-500, 500, 2)
    return m.Pose(0, t, x, y, 0.0, 0.0, 0.0, yaw, vx, vy, 0.0, 0.0, 0.0, yaw_rate, ax, ay, 0.0)


def roster(n: int, rng: np.random.Generator) -> dict[str, EgoTrack]:
    tracks = {}
    for i in range(n):
        info = m.EgoInfo(f"ego-{i}", "drive", "car", m.Extent(4.5, 1.8, 1.5), 1500.0)
        track = EgoTrack(info, "bench", 0.0)
        track.last_pose = turning_pose(rng, T - rng.uniform(0.0, 0.04))
        tracks[info.node_id] = track
    return tracks


def npc_rows(n: int, rng: np.random.Generator) -> np.ndarray:
    rows = np.zeros(n, dtype=m.NPC_DTYPE)
    yaw, speed = rng.uniform(-np.pi, np.pi, n), rng.uniform(0, 15, n)
    rows["x"], rows["y"] = rng.uniform(-500, 500, n), rng.uniform(-500, 500, n)
    rows["yaw"], rows["vx"], rows["vy"] = yaw, speed * np.cos(yaw), speed * np.sin(yaw)
    rows["yaw_rate"] = rng.uniform(-0.5, 0.5, n)
    rows["length"], rows["width"], rows["height"] = 4.5, 1.8, 1.5
    return rows


def best_us(call: Callable[[], object], calls: int, repeats: int) -> float:
    rounds = []
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(calls):
            call()
        rounds.append((time.process_time() - t0) / calls)
    return min(rounds) * 1e6


def measure(egos: int, npcs: int, repeats: int) -> list[tuple[str, float]]:
    rng = np.random.default_rng(7)
    tracks = roster(egos, rng)
    rows = npc_rows(npcs, rng)
    frame = NpcFrame(T, [f"npc{i}" for i in range(npcs)], rows)
    table = NpcTable(InterpolationSettings())
    table.add(m.NpcBatch.pack(0, T, frame.ids, rows), T)
    actors = []
    for track in tracks.values():
        actor = RemoteActor(track.info.node_id, InterpolationSettings())
        assert track.last_pose is not None
        actor.add(track.last_pose, T)
        actors.append(actor)

    def present() -> None:
        for actor in actors:
            actor.present(T + 0.03)

    def past() -> None:
        for actor in actors:
            actor.past(T + 0.03, T + 0.03)

    return [
        (f"authority egos_at, {egos} egos", best_us(lambda: egos_at(T, tracks, 0.5), 30, repeats)),
        (f"NpcFrame.at, {npcs} NPCs", best_us(lambda: frame.at(T + 0.03), 30, repeats)),
        (f"NpcTable.frame extrapolated, {npcs} NPCs",
         best_us(lambda: table.frame(T + 0.03, 0.5), 30, repeats)),
        (f"RemoteActor.present, {egos} egos", best_us(present, 3, repeats)),
        (f"RemoteActor.past beyond the newest, {egos} egos", best_us(past, 3, repeats)),
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--egos", type=int, default=256)
    parser.add_argument("--npcs", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=40)
    args = parser.parse_args(argv)
    for name, us in measure(args.egos, args.npcs, args.repeats):
        print(f"{name:<48} {us:9.1f} µs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
