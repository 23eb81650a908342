"""The drive node end to end: its own loop process, the fabric, real FFB and motion servers."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest
import yaml

from carlaverse import messages as m
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from carlaverse.hal.input.pursuit import scripted_route
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from carlaverse.keys import Keys
from tests.support import Cluster, demo_seen, wait_until


def drive_config(tmp: Path, ffb_port: int, motion_port: int) -> Path:
    config = {
        "node": {"kind": "drive"},
        "vehicle": "vehicles/compact-car.yaml",
        "input": {
            "backend": "sim",
            "options": {
                "mode": "path",
                "path": {
                    "waypoints": [list(p) for p in scripted_route()],
                    "target_speed_mps": 12.0,
                    "wheelbase_m": 2.64,
                    "max_steer_rad": 0.593,
                },
            },
        },
        "ffb": {"backend": "udp", "options": {"port": ffb_port}},
        "motion": {"backend": "udp", "options": {"port": motion_port}},
    }
    target = tmp / "drive-test.yaml"
    target.write_text(yaml.safe_dump(config))
    return target


def test_demo_with_a_drive_node_reaches_the_ffb_and_motion_servers(tmp_path: Path) -> None:
    with (
        FfbServer(LogActuator(LogActuatorOptions()), "127.0.0.1", 0) as ffb,
        MotionServer(LogPlatform(LogPlatformOptions()), "127.0.0.1", 0) as motion,
    ):
        config = drive_config(tmp_path, ffb.address[1], motion.address[1])
        demo_seen(
            "drive", "--scenario", "none", "--duration", "8", "--node-config", f"drive={config}"
        )
        assert ffb.stats.applied > 1000  # 500 Hz for most of 8 s
        assert motion.stats.frames > 200  # 100 Hz


# The car (configs/vehicles/compact-car.yaml) and the impulse the test sends it.
CAR_MASS_KG = 1350.0
IMPULSE_NS = -3000.0  # [N·s] along world x, through the car's centre: Δv = J/m, no spin
# Between two 50 Hz poses the tyres and the driver change the car's velocity by at most
# ~μ·g·20 ms ≈ 0.2 m/s; the impulse's 2.2 m/s jump must stand out from that by far.
DV_TOLERANCE_MPS = 0.5


def test_impulse_from_the_fabric_changes_the_cars_motion(cluster: Cluster) -> None:
    cluster.router()
    # in this process: nodes take impulses only from the authority's own session
    authority = cluster.in_process_authority()
    outbox = authority.start().outbox
    drive = cluster.start(
        "join", "drive", "--id", "car", "--session", "t", "--connect", cluster.endpoint,
        "--backend", "sim", "--duration", "6", "--json", name="car",
    )  # fmt: skip
    obs = cluster.observer()
    session = cluster.sessions[0]
    poses: list[m.Pose] = []
    sub = session.declare_subscriber(
        Keys("t").poses_of("car"), lambda s: poses.append(m.POSE.decode(s.payload.to_bytes()))
    )
    wait_until(lambda: len(poses) > 50, 30, "the car's poses")  # driving for ~1 s
    here = poses[-1]
    impulse = m.Impulse(
        1, obs.now(), 7, (IMPULSE_NS, 0.0, 0.0), (here.x, here.y, 0.0), (-1.0, 0.0, 0.0),
        "npc-1", "car", 2.0,
    )  # fmt: skip
    outbox.impulse("car", impulse)
    outbox.impulse("car", impulse)  # a duplicate: once only
    # an ADAS program takes over the pedals: the car's published state says so
    cruise = m.Override(1, obs.now(), "acc-test", cruise_speed_mps=8.0, expires_t=obs.now() + 30)
    session.put(Keys("t").override("car"), m.OVERRIDE.encode(cruise))

    def adas_visible() -> bool:
        obs.update()
        state = obs.world.ego_states.get("car")
        return state is not None and state.adas != ""

    wait_until(adas_visible, 5, "the override in the car's ego state")
    assert drive.wait(40) == 0
    # its loop process attached to the node's blocks; neither leaves the tracker confused
    assert "Traceback" not in "".join(drive.stderr), "".join(drive.stderr)[-2000:]
    sub.undeclare()
    authority.stop()
    _check_velocity_jump(sorted(poses, key=lambda p: p.t), impulse.t)
    summary = drive.json()
    assert summary["rejected"].get("impulse/duplicate") == 1, summary["rejected"]
    assert summary["impulses_accepted"] == 1
    loop = summary["extra"]["loop"]
    assert loop["impulses_applied"] == 1 and loop["impulses_dropped"] == 0
    assert loop["ticks"] > 3000 and loop["distance_m"] > 10
    assert isinstance(loop["control_stale_reads"], int)  # counted, and the loop lived on


def _check_velocity_jump(poses: list[m.Pose], impulse_t: float) -> None:
    """The largest change of world velocity between consecutive poses is the impulse's J/m,
    after its time, and no other change comes near it."""
    steps = [(b.t, b.vx - a.vx, b.vy - a.vy) for a, b in itertools.pairwise(poses)]
    t, dvx, dvy = max(steps, key=lambda s: math.hypot(s[1], s[2]))
    assert t >= impulse_t, f"the jump at {t:.3f} s precedes the impulse at {impulse_t:.3f} s"
    expected = IMPULSE_NS / CAR_MASS_KG  # [m/s] -2.22
    assert dvx == pytest.approx(expected, abs=DV_TOLERANCE_MPS), (dvx, dvy)
    assert abs(dvy) < DV_TOLERANCE_MPS, (dvx, dvy)
    others = [math.hypot(x, y) for s_t, x, y in steps if s_t != t]
    assert max(others) < DV_TOLERANCE_MPS, f"a {max(others):.2f} m/s change without an impulse"
