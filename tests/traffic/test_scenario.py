"""Scenario files: the shipped ones load, mistakes are named, networks are built once."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.config import ConfigError
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario
from carlaverse.traffic.sumo_tools import SumoMissingError, find_tool
from tests.traffic.helpers import CROSSING_MAP, T0, domain_of, run, write_scenario


@pytest.mark.parametrize("name", ["town", "crossing", "ring"])
def test_shipped_scenarios_validate(name: str) -> None:
    scenario = load_scenario(name)
    assert scenario.spec.name == name
    assert scenario.text == scenario.path.read_text(encoding="utf-8")  # kept byte for byte
    assert {"drive", "bike", "walk"} <= set(scenario.spec.egos)


def test_scenario_reply_is_the_file_as_run(tmp_path: Path, net_cache: Path) -> None:
    body = CROSSING_MAP + "seed: 5\n# a comment survives\ntraffic: {vehicles: {count: 0}}\n"
    path = write_scenario(tmp_path, body)
    with domain_of(path, net_cache, seed=9) as domain:
        reply = domain.scenario_reply()
    assert reply.yaml == path.read_text(encoding="utf-8") and reply.seed == 9
    assert reply.name == "test"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("map: {net: a.net.xml, osm: b.osm}\n", "exactly one map source"),
        ("map: {}\n", "exactly one map source"),
        (CROSSING_MAP + "trafic: {}\n", "unknown field `trafic`"),
        (CROSSING_MAP + "traffic: {vehicles: {count: -1}}\n", r"\$\.traffic\.vehicles\.count"),
        (CROSSING_MAP + "traffic: {vehicles: {mix: {tank: 1}}}\n", "unknown vehicle kinds"),
        (CROSSING_MAP + "egos: {drive: [{x: 1}]}\n", "either x and y, or a lane"),
        (CROSSING_MAP + "weather: {timeline: [{at_s: 9}, {at_s: 3}]}\n", "in time order"),
        (
            CROSSING_MAP + "lights: [{id: C, phases: [{duration_s: 5, state: GXr}]}]\n",
            r"phases\[0\]\.state",
        ),
    ],
)
def test_mistakes_name_the_file_and_field(tmp_path: Path, body: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as err:
        load_scenario(write_scenario(tmp_path, body))
    assert "test.yaml" in str(err.value)


def test_spawn_on_a_missing_lane_and_bad_scripted_route_are_config_errors(
    tmp_path: Path, net_cache: Path
) -> None:
    spawn = write_scenario(tmp_path, CROSSING_MAP + "egos: {drive: [{lane: nope_2}]}\n")
    with pytest.raises(ConfigError, match=r"egos\.drive\[0\]: no lane 'nope_2'"):
        domain_of(spawn, net_cache).__enter__()
    route = CROSSING_MAP + "traffic: {scripted_vehicles: [{id: x, edges: [WZ, nowhere]}]}\n"
    with pytest.raises(ConfigError, match="traffic does not fit the network"):
        domain_of(write_scenario(tmp_path, route, "route"), net_cache).__enter__()


def test_spawn_points_follow_the_lane_and_go_round_per_kind(net_cache: Path) -> None:
    with domain_of("crossing", net_cache) as domain:
        first = domain.spawn_point("drive", "d1")
        second = domain.spawn_point("drive", "d2")
        # two drive points, in turn; the third driver queues 10 m behind the first (heading
        # east: 10 m further west), never on top of it
        third = domain.spawn_point("drive", "d3")
        assert (third.x, third.y, third.yaw) == pytest.approx((first.x - 10.0, first.y, first.yaw))
        assert domain.spawn_point("drive", "d1") == first  # a re-join gets its point back
        assert first != second
        assert abs(first.yaw) < 1e-6  # WZ runs east
        assert domain.spawn_point("observer", "o") is None  # no points, no default


def test_network_is_built_once_and_rebuilt_when_its_input_changes(tmp_path: Path) -> None:
    maps = tmp_path / "maps"
    maps.mkdir()
    src = Path(load_scenario("crossing").base_dir) / "maps"
    for name in ("crossing.nod.xml", "crossing.edg.xml", "crossing.con.xml"):
        (maps / name).write_bytes((src / name).read_bytes())
    body = "map: {plain: {nodes: maps/crossing.nod.xml, edges: maps/crossing.edg.xml}}\n"
    scenario = load_scenario(write_scenario(tmp_path, body))
    cache = tmp_path / "cache"
    first = build_map(scenario, cache).net
    stamp = first.stat().st_mtime_ns
    assert build_map(scenario, cache).net == first and first.stat().st_mtime_ns == stamp
    nodes = maps / "crossing.nod.xml"
    nodes.write_text(nodes.read_text().replace('x="120"', 'x="130"'), encoding="utf-8")
    rebuilt = build_map(scenario, cache).net
    assert rebuilt != first and rebuilt.is_file()
    assert not list(cache.rglob("*.tmp.xml"))  # no half-written leftovers


def test_missing_sumo_program_says_how_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SUMO_HOME", os.devnull)
    monkeypatch.setenv("PATH", "")
    monkeypatch.setattr("carlaverse.traffic.sumo_tools.sumo_homes", lambda: [])
    with pytest.raises(
        SumoMissingError, match=r"netgenerate.*pip install 'carlaverse\[authority\]'"
    ):
        find_tool("netgenerate")


def test_generated_spider_town_with_bike_lanes_runs(tmp_path: Path, net_cache: Path) -> None:
    body = """
map: {generate: {kind: spider, spider: {arms: 5, circles: 2, radius_m: 80}, bike_lanes: true}}
traffic: {vehicles: {count: 10, mix: {car: 1, bicycle: 0.3}}, pedestrians: {count: 10}}
"""
    with domain_of(write_scenario(tmp_path, body, "spider"), net_cache) as domain:
        out = MemoryOutbox()
        run(domain, out, T0, 5.0)
        kinds = {lane.kind for lane in domain.map_reply().lanes}
        assert {"road", "bike", "sidewalk", "crossing", "walkingarea"} <= kinds
        assert len(out.npcs[-1].ids) >= 15  # 10 vehicles and 10 walkers, a few still entering
        assert domain.map_reply().lights  # the centre and ring junctions are signalised
