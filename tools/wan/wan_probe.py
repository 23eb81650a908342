"""A measuring observer for WAN tests and benchmarks: every renderer, against the true path.

    python tools/wan/wan_probe.py --id probe-a --session wan \\
        --connect tcp/127.0.0.1:7447 --target b-bike=bike.yaml --duration 30

Joins as an observer (a real `NodeClient`: clock sync, presence, despawns) and, at `--rate-hz`,
draws each target with every renderer of `carlaverse.testing.render_metrics` (the world view
in past and present mode, and naive) from the same pose stream. Targets are scripted nodes
whose config (path) is given, so their true path is known; `render_metrics.probe_metrics`
turns the report into the same figures the in-process benchmark gives.

Prints `ready` on stderr once every target has been drawn, and `presence <id> <0|1> <t>`
whenever a target appears in or leaves the observer's world; on exit (duration or SIGINT)
prints JSON: the raw frames, each stamped with the host's monotonic clock (shared by all
network namespaces) so a harness can cut them into windows around the events it caused.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import zenoh
from carlaverse_nodes.scripted import ScriptedConfig
from carlaverse_nodes.scripted.trajectories import PathSpec

from carlaverse import messages as m
from carlaverse.config import load_config
from carlaverse.keys import Keys, KeySpaceError, parse
from carlaverse.testing.render_metrics import RENDERERS, RendererSet
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session

SCRIPT = Path(__file__).resolve()


class Probe:
    def __init__(self, client: NodeClient, targets: dict[str, PathSpec]) -> None:
        self.client = client
        self.targets = targets
        settings = client.settings.interpolation
        self.renderers = {t: RendererSet(t, settings) for t in targets}
        self.inbox: deque[tuple[str, m.Pose, float]] = deque(maxlen=100_000)
        # [monotonic t, target, present in the world, {renderer: frame}]
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
        """Drain, draw, record; True once every target has been drawn."""
        now = self.client.update()
        while self.inbox:
            node_id, pose, rx_t = self.inbox.popleft()
            self.renderers[node_id].add(pose, rx_t)
        mono = time.monotonic()
        drawn = True
        for target, renderers in self.renderers.items():
            frames = {k: [round(v, 6) for v in f] for k, f in renderers.frame(now).items()}
            drawn = drawn and len(frames) == len(RENDERERS)
            present = target in self.client.world.egos
            self.samples.append([round(mono, 4), target, present, frames])
            if present != self.present[target]:
                self.present[target] = present
                print(f"presence {target} {int(present)} {mono:.4f}", file=sys.stderr, flush=True)
        return drawn

    def report(self) -> dict[str, Any]:
        world = self.client.world
        return {
            "node_id": self.client.node_id,
            "joined": self.client.admitted.is_set(),
            "seen": sorted(world.seen),
            "despawns": [(d.actor_id, d.reason) for d in world.despawns],
            "bad_samples": self.bad,
            "samples": self.samples,
        }


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python tools/wan/wan_probe.py")
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
