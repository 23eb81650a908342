"""Road grades from the scenario: the schema, the lookup, and the bike feeling the climb."""

from __future__ import annotations

import math
import threading
from pathlib import Path

import pytest
import yaml
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, resolve_table
from carlaverse_nodes.bike.road_grade import RoadGrade
from carlaverse_nodes.bike.shared_state import STATE

from carlaverse import messages as m
from carlaverse.authority.domain import EmptyDomain
from carlaverse.authority.service import Authority, AuthoritySettings
from carlaverse.config import ConfigError
from carlaverse.shm import SharedBlock, block_name
from carlaverse.traffic.scenario import load_scenario
from carlaverse.transport.clock import WallAlignedClock
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

HILL = """\
name: hill
map: {net: hill.net.xml}
grades:
  default_percent: 1.5
  areas:
    - name: ramp
      polygon: [[10, -5], [60, -5], [60, 5], [10, 5]]
      grade_percent: 5
      uphill_yaw_deg: 0
    - polygon: [[0, 20], [40, 20], [40, 30], [10, 30], [10, 60], [0, 60]]  # an L
      grade_percent: 8
      uphill_yaw_deg: 90
"""


def scenario_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "hill.yaml"
    path.write_text(text)
    return path


def test_a_scenario_declares_grades_and_the_shipped_crossing_has_a_climb(tmp_path: Path) -> None:
    grades = load_scenario(scenario_file(tmp_path, HILL)).spec.grades
    assert grades.default_percent == 1.5
    assert [(a.name, a.grade_percent, a.uphill_yaw_deg) for a in grades.areas] == [
        ("ramp", 5.0, 0.0), ("", 8.0, 90.0),
    ]  # fmt: skip
    crossing = load_scenario("crossing").spec.grades.areas
    assert [(a.grade_percent, a.uphill_yaw_deg) for a in crossing] == [(5.0, 90.0)]
    assert load_scenario("town").spec.grades.areas == []  # flat: the node's config decides


@pytest.mark.parametrize(
    ("bad", "path"),
    [
        ("grade_percent: 5", "grade_percent: 55"),
        ("uphill_yaw_deg: 0", "uphill: 0"),
        ("[[10, -5], [60, -5], [60, 5], [10, 5]]", "[[10, -5], [60, -5]]"),
    ],
)
def test_a_bad_grade_is_named_by_its_field_path(tmp_path: Path, bad: str, path: str) -> None:
    with pytest.raises(ConfigError) as caught:
        load_scenario(scenario_file(tmp_path, HILL.replace(bad, path, 1)))
    message = str(caught.value)
    assert "hill.yaml" in message and "$.grades.areas[0]" in message
    assert message.count("\n") == 0  # one line for the user


def test_the_node_reads_only_the_grades_and_names_a_bad_one() -> None:
    newer = HILL.replace("map: {net: hill.net.xml}", "map: {teleport: yes}")  # unknown to us
    assert RoadGrade.from_scenario_yaml(newer).at(30.0, 0.0, 0.0) == pytest.approx(5.0)
    with pytest.raises(ConfigError, match=r"authority/scenario: .*\$\.default_percent"):
        RoadGrade.from_scenario_yaml("grades: {default_percent: 90}")
    assert RoadGrade.from_scenario_yaml("name: flat").at(0.0, 0.0, 0.0) is None


def test_the_grade_felt_follows_the_heading_inside_an_area_and_the_default_outside() -> None:
    grade = RoadGrade.from_scenario_yaml(HILL)
    assert grade.at(30.0, 0.0, 0.0) == pytest.approx(5.0)  # riding east, up the ramp
    assert grade.at(30.0, 0.0, math.pi) == pytest.approx(-5.0)  # back down
    assert grade.at(30.0, 0.0, math.pi / 2) == pytest.approx(0.0, abs=1e-12)  # across
    assert grade.at(30.0, 0.0, math.pi / 3) == pytest.approx(2.5)  # cos 60° of the climb
    assert grade.at(5.0, 40.0, math.pi / 2) == pytest.approx(8.0)  # the L's upright
    assert grade.at(30.0, 40.0, math.pi / 2) == 1.5  # in the L's box, outside its notch
    assert grade.at(61.0, 0.0, 0.0) == 1.5  # beyond the ramp's end
    silent = RoadGrade.from_scenario_yaml(HILL.replace("  default_percent: 1.5\n", ""))
    assert silent.at(61.0, 0.0, 0.0) is None  # the node's road.grade_percent applies


def test_the_trainer_command_rises_when_the_loop_is_told_of_a_climb() -> None:
    config = BikeNodeConfig()
    loop = BikeLoop(config, resolve_table(config))
    flat = loop.step(0.005, 6.0, 0.0, 0.0)
    loop.grade_percent = 5.0
    climb = loop.step(0.005, 6.0, 0.0, 0.0)
    assert climb.resistance_n - flat.resistance_n == pytest.approx(
        90 * 9.81 * (math.sin(math.atan(0.05)) + 0.004 * (math.cos(math.atan(0.05)) - 1)),
        rel=1e-6,
    )  # fmt: skip
    assert climb.resistance_percent > flat.resistance_percent + 10


class ScenarioOnly(EmptyDomain):
    """Membership plus a scenario to serve on `authority/scenario` (no engine needed)."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.reply = m.ScenarioReply(m.SCHEMA_VERSION, "hill", text)

    def scenario_reply(self) -> m.ScenarioReply:
        return self.reply


def test_the_bike_node_feels_the_scenario_climb(cluster: Cluster, tmp_path: Path) -> None:
    """A bike rolling east at 5 m/s from the origin rides onto the ramp at x = 10 m: the grade
    goes from the config's fallback (the scenario's default is removed) to the climb, and the
    trainer's command rises with it."""
    text = HILL.replace("  default_percent: 1.5\n", "")
    load_scenario(scenario_file(tmp_path, text))  # a valid scenario, not just a grades block
    config = tmp_path / "bike.yaml"
    config.write_text(yaml.safe_dump({
        "road": {"grade_percent": 1.0},
        "speed_source": "speed_sensor",
        "speed_sensor": {"backend": "sim", "options": {"profile": [{"t": 0, "speed_mps": 5.0}]}},
        "trainer": {"backend": "ftms_sim", "options": {"rider_power_w": 0}},
    }))  # fmt: skip
    cluster.router()
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    domain = ScenarioOnly(text)
    authority = Authority(session, AuthoritySettings(session="t"), WallAlignedClock(), domain)
    threading.Thread(target=authority.start().run, daemon=True).start()
    bike = cluster.start(
        "join", "bike", "--id", "climber", "--session", "t", "--connect", cluster.endpoint,
        "--config", str(config), "--duration", "30", "--json", name="climber",
    )  # fmt: skip
    try:
        state = wait_until(lambda: _attach(block_name("t", "climber", "state")), 30, "the state")
        running = lambda: (s := state.read())["running"] and s  # noqa: E731
        flat = wait_until(lambda: (s := running()) and 2.0 < s["x"] < 8.0 and s, 20, "x ≈ 5 m")
        climb = wait_until(lambda: (s := running()) and s["x"] > 15.0 and s, 20, "x > 15 m")
        state.close()
    finally:
        assert bike.stop() == 0, bike.output()[-2000:]
        authority.close()
        session.close()
    assert flat["grade_percent"] == 1.0  # outside every area, no default: the config's
    assert climb["grade_percent"] == pytest.approx(5.0, abs=0.05)  # riding straight up it
    assert climb["resistance_percent"] > flat["resistance_percent"] + 10
    assert bike.json()["extra"]["scenario_grade_areas"] == 2


def _attach(name: str) -> SharedBlock | None:
    """The node's state block, read as its HMI page would."""
    try:
        block = SharedBlock(name, STATE)
    except FileNotFoundError:
        return None
    return block
