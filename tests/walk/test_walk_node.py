"""The walk node end to end: its own loop process, the fabric, the demo."""

from __future__ import annotations

import json
import math
import subprocess
import sys

from carlaverse import messages as m
from tests.support import Cluster, wait_until


def test_demo_with_a_walker_and_a_scripted_car_headless() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "carlaverse", "demo", "--nodes", "walk,scripted",
         "--scenario", "none", "--duration", "6", "--json", "--quiet"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["all_seen"], summary["nodes"]
    assert "walk-1" in summary["nodes"]["scripted-2"]["actors_seen"]
    assert summary["nodes"]["walk-1"]["poses_sent"] > 100  # 50 Hz for most of 6 s


def test_the_sim_walker_walks_as_a_pedestrian(cluster: Cluster) -> None:
    cluster.router()
    cluster.authority()
    walker = cluster.start(
        "join", "walk", "--id", "walker", "--session", "t", "--connect", cluster.endpoint,
        "--backend", "sim", "--duration", "60", "--json", name="walker",
    )  # fmt: skip
    obs = cluster.observer()

    def walking() -> bool:
        obs.update()
        actor = obs.world.egos.get("walker")
        pose = actor.newest if actor else None
        return pose is not None and math.hypot(pose.vx, pose.vy) > 1.3

    wait_until(walking, 30, "the walker at walking pace (> 1.3 m/s)")
    snapshot = m.SNAPSHOT.decode(obs.query("snapshot"))
    info = next(e for e in snapshot.egos if e.node_id == "walker")
    assert (info.kind, info.actor_kind) == ("walk", "pedestrian")  # what the authority carries
    pose = obs.world.egos["walker"].newest
    assert math.hypot(pose.vx, pose.vy) <= 1.4 + 1e-6  # the walk limit: `run` is not held yet
    # The script walks forward along the head's yaw; the head looks around by ±0.3 rad.
    heading = math.atan2(pose.vy, pose.vx)
    assert abs(math.atan2(math.sin(heading - pose.yaw), math.cos(heading - pose.yaw))) < 0.35

    def jogging() -> bool:
        obs.update()
        p = obs.world.egos["walker"].newest
        return p is not None and math.hypot(p.vx, p.vy) > 2.5

    wait_until(jogging, 20, "the walker jogging (> 2.5 m/s) once `run` is held")
    assert walker.stop() == 0
    report = walker.json()["extra"]
    loop = report["loop"]
    assert loop["headset"] == "SimHeadset"
    assert loop["ticks"] > 90 * 5  # 90 Hz for the ≥ 8 s it took to jog
    assert loop["distance_m"] > 8.0
    assert report["skeletons_sent"] == 0  # `body: none`
