"""A drive node drives over the scenario's speed bump: the authority serves the scenario, the
node hands its `surface:` to the control loop, and the motion server on 127.0.0.1 receives a
heave that goes up first, in FRAME_UPDATEs it decodes itself."""

from __future__ import annotations

import threading
from pathlib import Path

import yaml

from carlaverse import messages as m
from carlaverse.authority.domain import EmptyDomain
from carlaverse.authority.service import Authority, AuthoritySettings
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from carlaverse.traffic.scenario import load_scenario
from carlaverse.transport.clock import WallAlignedClock
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster

# A hump 8 cm high and 3 m long across the road at x = 40 m. The node's car spawns at the
# origin heading east (the scenario has no spawn points) and a scripted driver holds 8 m/s
# along y = 0: it is at speed well before the hump (about 3 s and 12 m to get there).
STREET = """\
name: street
map: {net: street.net.xml}
surface:
  bumps:
    - {name: hump, line: [[40, -4], [40, 4]], height_m: 0.08, length_m: 3}
"""


class ScenarioOnly(EmptyDomain):
    """Membership plus a scenario to serve on `authority/scenario` (no engine needed)."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.reply = m.ScenarioReply(m.SCHEMA_VERSION, "street", text)

    def scenario_reply(self) -> m.ScenarioReply:
        return self.reply


def drive_config(tmp_path: Path, motion_port: int) -> Path:
    driver = {"waypoints": [[0, 0], [400, 0]], "target_speed_mps": 8.0, "wheelbase_m": 2.64,
              "max_steer_rad": 0.593}  # fmt: skip
    config = {
        "node": {"kind": "drive"},
        "input": {"backend": "sim", "options": {"mode": "path", "path": driver}},
        "motion": {"backend": "udp", "options": {"port": motion_port}},
        "loop": {"motion_rate_hz": 200},
        "road": {"roughness_class": None},  # a smooth road, and ...
        # ... only the vertical-jerk term heaves the rig (the launch's longitudinal jerk would
        # heave it too, by design): any heave is the hump's.
        "motion_cueing": {"k_jx_m_per_mps3": 0.0},
    }
    path = tmp_path / "drive.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_the_rig_heaves_up_first_over_the_scenarios_speed_bump(
    cluster: Cluster, tmp_path: Path
) -> None:
    scenario = tmp_path / "street.yaml"
    scenario.write_text(STREET)
    load_scenario(scenario)  # a valid scenario, not just a surface block
    cluster.router()
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    domain = ScenarioOnly(STREET)
    authority = Authority(session, AuthoritySettings(session="t"), WallAlignedClock(), domain)
    threading.Thread(target=authority.start().run, daemon=True).start()
    with MotionServer(LogPlatform(LogPlatformOptions()), "127.0.0.1", 0) as server:
        config = drive_config(tmp_path, server.address[1])
        car = cluster.start(
            "join", "drive", "--id", "car", "--session", "t", "--connect", cluster.endpoint,
            "--config", str(config), "--duration", "12", "--json", name="car",
        )  # fmt: skip
        try:
            assert car.wait(60) == 0, car.output()[-2000:]
        finally:
            authority.close()
            session.close()
        platform: LogPlatform = server.platform  # type: ignore[assignment]
        frames = platform.frames()
    loop = car.json()["extra"]["loop"]
    assert loop["surface_features"] == 1  # the scenario's hump reached the loop
    assert loop["distance_m"] > 60.0  # the car got over the hump (at x = 40 m)
    heave = [f.heave for f in frames]
    # Up first: the wheels climb, the body follows, the paper's vertical-jerk term lifts the
    # rig before it drops it. And clearly felt: over a fifth of the ±25 mm platform.
    first = next(h for h in heave if abs(h) > 0.001)
    assert first > 0.0
    assert max(heave) > 0.005
    assert server.stats.invalid_value == 0
