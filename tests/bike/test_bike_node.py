"""The bike node end to end: its own loop process, the fabric, a real FFB server."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
import yaml
from carlaverse_nodes.bike.shared_state import STATE

from carlaverse import messages as m
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from carlaverse.shm import SharedBlock, block_name
from tests.support import Cluster, demo_seen, wait_until


def test_demo_sees_the_bike_and_its_fork_reaches_the_ffb_server(tmp_path: Path) -> None:
    with FfbServer(LogActuator(LogActuatorOptions()), "127.0.0.1", 0) as ffb:
        config = tmp_path / "bike.yaml"
        config.write_text(yaml.safe_dump({
            "node": {"kind": "bike", "actor_kind": "bicycle"},
            "input": {"backend": "sim", "options": {"axes": ["steer"], "profile": [
                {"t": 0, "axes": {"steer": 0.0}}, {"t": 3, "axes": {"steer": 0.2}}]}},
            "ffb": {"backend": "udp", "options": {"port": ffb.address[1]}},
            "road": {"grade_percent": 4.0, "roughness": 0.5},
        }))  # fmt: skip
        demo_seen(
            "bike", "--scenario", "none", "--duration", "8", "--node-config", f"bike={config}"
        )
        assert ffb.stats.applied > 500  # 200 Hz fork commands for most of 8 s


def test_an_impulse_from_the_fabric_throws_the_bike(cluster: Cluster) -> None:
    cluster.router()
    # in this process: nodes take impulses only from the authority's own session
    authority = cluster.in_process_authority()
    outbox = authority.start().outbox
    bike = cluster.start(
        "join", "bike", "--id", "rider", "--session", "t", "--connect", cluster.endpoint,
        "--backend", "sim", "--duration", "60", "--json", name="rider",
    )  # fmt: skip
    obs = cluster.observer()

    def riding() -> bool:
        obs.update()
        actor = obs.world.egos.get("rider")
        pose = actor.newest if actor else None
        return pose is not None and abs(pose.roll) < 0.8 and math.hypot(pose.vx, pose.vy) > 1.5

    wait_until(riding, 30, "the bike upright, faster than 1.5 m/s")
    # A view measures motion-to-photon from the loop's own stamp on the state it draws: the
    # stamp is the host's monotonic clock at the write, so it lies between two readings of
    # that clock taken around a read of the block, within a few 200 Hz ticks of the later.
    block = SharedBlock(block_name("t", "rider", "state"), STATE)
    try:
        before = time.monotonic_ns()
        written = int(block.read()["written_ns"])
        after = time.monotonic_ns()
    finally:
        block.close()
    assert before - 1_000_000_000 < written <= after, (before, written, after)
    pose = obs.world.egos["rider"].newest
    assert pose is not None
    side = (-math.sin(pose.yaw) * 450.0, math.cos(pose.yaw) * 450.0, 0.0)  # 5 m/s to the left
    impulse = m.Impulse(1, obs.now(), 3, side, (pose.x, pose.y, 0.5), (0.0, 1.0, 0.0),
                        "npc-1", "car", 5.0)  # fmt: skip
    outbox.impulse("rider", impulse)
    outbox.impulse("rider", impulse)  # a duplicate: applied once

    def fallen() -> bool:
        obs.update()
        newest = obs.world.egos["rider"].newest
        return newest is not None and abs(newest.roll) > 1.5  # lying on its side

    wait_until(fallen, 10, "the bike on its side")
    # pushed toward its left, it lies on its left side: ISO 8855 roll, left side down, is < 0
    assert obs.world.egos["rider"].newest.roll < 0
    wait_until(riding, 10, "the rider back on the bike")  # after the 3 s fall hold
    assert bike.stop() == 0  # SIGINT: a clean leave with the summary
    authority.stop()
    loop = bike.json()["extra"]["loop"]
    assert loop["impulses_applied"] == 1 and loop["impulses_dropped"] == 0
    assert loop["ticks"] > 200 * 3  # 200 Hz through the 3 s the rider lay on the road
    assert loop["trainer"]["resistance_sent"] >= 3  # the table's command reached the trainer


def test_the_wheel_speed_sensor_drives_the_bike(cluster: Cluster, tmp_path: Path) -> None:
    """speed_source: speed_sensor — the bike covers what the wheel says, not the trainer."""
    config = tmp_path / "bike.yaml"
    config.write_text(yaml.safe_dump({
        "speed_source": "speed_sensor",
        "speed_sensor": {"backend": "sim", "options": {"profile": [{"t": 0, "speed_mps": 5.0}]}},
        "trainer": {"backend": "ftms_sim", "options": {"rider_power_w": 0}},
    }))  # fmt: skip
    cluster.router()
    cluster.authority()
    bike = cluster.start(
        "join", "bike", "--id", "solo", "--session", "t", "--connect", cluster.endpoint,
        "--config", str(config), "--duration", "4", "--json", name="solo",
    )  # fmt: skip
    assert bike.wait(60) == 0, bike.output()[-2000:]
    loop = bike.json()["extra"]["loop"]
    assert loop["ticks"] > 200
    assert loop["distance_m"] == pytest.approx(5.0 * loop["ticks"] / 200, rel=0.01)
    assert loop["trainer"]["resistance_sent"] >= 1  # the flat road's command at 5 m/s
