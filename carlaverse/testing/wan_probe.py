"""A measuring observer for WAN tests: how far remote actors are drawn from their true path.

    python -m carlaverse.testing.wan_probe --id probe-a --session wan \\
        --connect tcp/127.0.0.1:7447 --target b-bike=bike.yaml --duration 30

Joins as an observer (a real `NodeClient`: clock sync, presence, despawns) and, at `--rate-hz`,
renders each target three ways from the same pose stream:
- `adaptive`: a `RemoteActor` whose delay follows the stream's interval and jitter (DESIGN §6);
- `fixed`: the same with `adaptive: false`, i.e. the starting delay of two send intervals;
- `naive`: the last sample received, drawn as is, now.
The error of the first two is the distance to the true path at the time they show
(`render_t`); the naive one is drawn now, so its error is against the true position now.
Targets are scripted nodes whose config (path) is given, so their true path is known.

Prints `ready` on stderr once every target has been rendered, and `presence <id> <0|1> <t>`
whenever a target appears in or leaves the observer's world; on exit (duration or SIGINT)
prints JSON: the raw samples, each stamped with the host's monotonic clock (shared by all
network namespaces) so a harness can cut them into windows around the events it caused.
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import msgspec
import zenoh
from carlaverse_nodes.scripted import ScriptedConfig

from carlaverse import messages as m
from carlaverse.config import load_config
from carlaverse.fabric.clock import MonotonicClock
from carlaverse.fabric.node_client import NodeClient, NodeSettings
from carlaverse.fabric.remote_actor import RemoteActor
from carlaverse.fabric.session import FabricSettings, open_session
from carlaverse.keys import Keys, KeySpaceError, parse
from carlaverse.paths import PathSpec

VARIANTS = ("adaptive", "fixed", "naive")


class Probe:
    def __init__(self, client: NodeClient, targets: dict[str, PathSpec]) -> None:
        self.client = client
        self.targets = targets
        settings = client.settings.interpolation
        fixed = msgspec.structs.replace(settings, adaptive=False)
        self.actors = {
            t: {"adaptive": RemoteActor(t, settings), "fixed": RemoteActor(t, fixed)}
            for t in targets
        }
        self.last: dict[str, m.Pose] = {}
        self.inbox: deque[tuple[str, m.Pose, float]] = deque(maxlen=100_000)
        # [monotonic t, target, adaptive, fixed, naive error [m], present, adaptive delay [ms]]
        self.samples: list[list[Any]] = []
        self.present: dict[str, bool] = dict.fromkeys(targets, False)
        self.bad = 0

    def on_pose(self, sample: zenoh.Sample) -> None:
        rx_t = self.client.now()
        try:
            node_id = parse(str(sample.key_expr)).node_id
            pose = m.POSE.decode(sample.payload.to_bytes())
        except (KeySpaceError, m.MessageError):
            self.bad += 1
            return
        if node_id in self.targets:
            self.inbox.append((node_id, pose, rx_t))

    def step(self) -> bool:
        """Drain, render, measure; True once every target has a measurement."""
        now = self.client.update()
        while self.inbox:
            node_id, pose, rx_t = self.inbox.popleft()
            for actor in self.actors[node_id].values():
                actor.add(pose, rx_t)
            if node_id not in self.last or pose.t > self.last[node_id].t:
                self.last[node_id] = pose
        mono = time.monotonic()
        for target, path in self.targets.items():
            errors = [self._error(target, path, v, now) for v in VARIANTS]
            present = target in self.client.world.egos
            delay_ms = round(self.actors[target]["adaptive"].delay_s * 1e3, 2)
            self.samples.append([round(mono, 4), target, *errors, present, delay_ms])
            if present != self.present[target]:
                self.present[target] = present
                print(f"presence {target} {int(present)} {mono:.4f}", file=sys.stderr, flush=True)
        return all(t in self.last for t in self.targets)

    def _error(self, target: str, path: PathSpec, variant: str, now: float) -> float | None:
        if variant == "naive":
            last = self.last.get(target)
            if last is None:
                return None
            true = path.pose_at(now)
            return round(math.hypot(last.x - true.x, last.y - true.y), 5)
        view = self.actors[target][variant].view(now)
        if view is None:
            return None
        true = path.pose_at(view.render_t)
        return round(math.hypot(view.x - true.x, view.y - true.y), 5)

    def report(self) -> dict[str, Any]:
        world = self.client.world
        return {
            "node_id": self.client.node_id,
            "joined": self.client.admitted.is_set(),
            "seen": sorted(world.seen),
            "despawns": [(d.actor_id, d.reason) for d in world.despawns],
            "bad_samples": self.bad,
            "delay_ms": {
                t: {v: round(a.delay_s * 1e3, 2) for v, a in actors.items()}
                for t, actors in self.actors.items()
            },
            "samples": self.samples,
        }


def window(report: dict[str, Any], target: str, start: float, end: float) -> list[list[Any]]:
    """The samples of `target` taken between monotonic times `start` and `end`."""
    return [r for r in report["samples"] if r[1] == target and start <= r[0] <= end]


def error_stats(rows: list[list[Any]], variant: str) -> dict[str, float]:
    """p50, p95, p99 and max [m] of one variant's error over `rows` (measured ones only)."""
    column = 2 + VARIANTS.index(variant)
    values = sorted(r[column] for r in rows if r[column] is not None)
    if not values:
        return {"n": 0, "p50": math.nan, "p95": math.nan, "p99": math.nan, "max": math.nan}

    def q(p: float) -> float:
        return round(values[min(len(values) - 1, int(p * len(values)))], 4)

    return {"n": len(values), "p50": q(0.5), "p95": q(0.95), "p99": q(0.99), "max": values[-1]}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m carlaverse.testing.wan_probe")
    parser.add_argument("--id", required=True, help="the probe's node id")
    parser.add_argument("--session", required=True)
    parser.add_argument("--connect", action="append", default=[], metavar="EP")
    parser.add_argument("--target", action="append", default=[], metavar="ID=SCRIPTED.yaml")
    parser.add_argument("--duration", type=float, default=60.0, metavar="S")
    parser.add_argument("--rate-hz", type=float, default=100.0)
    return parser.parse_args(argv)


def load_targets(specs: list[str]) -> dict[str, PathSpec]:
    out = {}
    for spec in specs:
        node_id, _, config = spec.partition("=")
        out[node_id] = load_config(Path(config), ScriptedConfig).path
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    targets = load_targets(args.target)
    settings = NodeSettings(node_id=args.id, session=args.session, kind="observer", actor_kind="")
    session = open_session(FabricSettings(connect=args.connect))
    client = NodeClient(session, settings, MonotonicClock()).start()
    probe = Probe(client, targets)
    subscriber = session.declare_subscriber(Keys(args.session).all_ego("pose"), probe.on_pose)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    _run(probe, args, stop)
    subscriber.undeclare()
    client.close()
    session.close()
    sys.stdout.write(json.dumps(probe.report()) + "\n")
    return 0


def _run(probe: Probe, args: argparse.Namespace, stop: threading.Event) -> None:
    period = 1.0 / args.rate_hz
    end = time.monotonic() + args.duration
    next_t = time.monotonic()
    announced = False
    while not stop.is_set() and time.monotonic() < end:
        if probe.step() and not announced:
            print("ready", file=sys.stderr, flush=True)
            announced = True
        next_t += period
        stop.wait(max(0.0, next_t - time.monotonic()))


if __name__ == "__main__":
    sys.exit(main())
