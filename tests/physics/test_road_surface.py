"""The scenario's road surface: the schema, and the shapes of bumps, kerbs and potholes."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.physics.road_surface import Kerb, Pothole, RoadProfile, RoadSurface, SpeedBump
from carlaverse.traffic.scenario import load_scenario

STREET = """\
name: street
map: {net: street.net.xml}
surface:
  roughness_class: C
  roughness_seed: 4
  bumps:
    - {name: school, line: [[20, -4], [20, 4]], height_m: 0.08, length_m: 3}
  kerbs:
    - {name: island, polygon: [[40, -1], [50, -1], [50, 1], [40, 1]], height_m: 0.12, edge_m: 0.2}
  potholes:
    - {x: 60, y: 1, radius_m: 0.4, depth_m: 0.05}
"""


def scenario_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "street.yaml"
    path.write_text(text)
    return path


def test_a_scenario_declares_its_surface(tmp_path: Path) -> None:
    surface = load_scenario(scenario_file(tmp_path, STREET)).spec.surface
    assert (surface.roughness_class, surface.roughness_seed) == ("C", 4)
    assert [b.name for b in surface.bumps] == ["school"] and surface.feature_count() == 3
    assert load_scenario("town").spec.surface == RoadSurface()  # silent: the node's road


@pytest.mark.parametrize(
    ("bad", "good", "path"),
    [
        ("height_m: 0.08", "height_m: -0.08", "$.surface.bumps[0].height_m"),
        ("length_m: 3", "length: 3", "$.surface.bumps[0]"),
        ("[[20, -4], [20, 4]]", "[[20, -4], [20, -4]]", "$.surface.bumps[0]"),
        ("roughness_class: C", "roughness_class: Z", "$.surface.roughness_class"),
        ("edge_m: 0.2", "edge_m: 0", "$.surface.kerbs[0].edge_m"),
        ("depth_m: 0.05", "depth_m: 2", "$.surface.potholes[0].depth_m"),
    ],
)
def test_a_bad_surface_entry_is_named_by_its_field_path(
    tmp_path: Path, bad: str, good: str, path: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        load_scenario(scenario_file(tmp_path, STREET.replace(bad, good, 1)))
    message = str(caught.value)
    assert "street.yaml" in message and path in message
    assert message.count("\n") == 0  # one line for the user


def test_the_node_reads_only_the_surface_and_names_a_bad_one() -> None:
    newer = STREET.replace("map: {net: street.net.xml}", "map: {teleport: yes}")  # unknown
    assert RoadSurface.from_scenario_yaml(newer).feature_count() == 3
    with pytest.raises(ConfigError, match=r"authority/scenario: .*\$\.bumps\[0\]\.height_m"):
        RoadSurface.from_scenario_yaml(STREET.replace("height_m: 0.08", "height_m: 9"))
    assert RoadSurface.from_scenario_yaml("name: flat") == RoadSurface()


def test_a_speed_bump_is_a_raised_cosine_across_its_line() -> None:
    # Crest line x = 20, y from −4 to 4; height 0.08 m over 3 m of travel (x 18.5 … 21.5).
    road = RoadProfile(RoadSurface(bumps=[SpeedBump(line=[(20, -4), (20, 4)], height_m=0.08,
                                                    length_m=3)]), None)  # fmt: skip
    assert road.height(20.0, 0.0, 0.0) == pytest.approx(0.08)  # the crest
    assert road.height(20.75, 3.9, 0.0) == pytest.approx(0.04)  # a quarter in: h/2·(1+cos 90°)
    assert road.height(19.25, -3.9, 0.0) == pytest.approx(0.04)  # symmetric
    for x, y in ((18.5, 0.0), (21.5, 0.0), (17.0, 0.0), (20.0, 4.5), (20.0, -4.5)):
        assert road.height(x, y, 0.0) == pytest.approx(0.0, abs=1e-15)  # feet and beyond


def test_a_kerb_rises_over_its_edge_and_a_pothole_dips_and_they_add() -> None:
    island = Kerb(polygon=[(40, -1), (50, -1), (50, 1), (40, 1)], height_m=0.12, edge_m=0.2)
    hole = Pothole(x=45, y=0.5, radius_m=0.4, depth_m=0.05)
    road = RoadProfile(RoadSurface(kerbs=[island], potholes=[hole]), None)
    assert road.height(39.99, 0.0, 0.0) == 0.0  # outside
    assert road.height(40.1, 0.0, 0.0) == pytest.approx(0.06)  # half the edge: h/2
    assert road.height(40.2, 0.0, 0.0) == pytest.approx(0.12)  # the edge's top
    assert road.height(43.0, -0.5, 0.0) == pytest.approx(0.12)  # on the island
    assert road.height(45.0, 0.5, 0.0) == pytest.approx(0.12 - 0.05)  # the hole in the island
    assert road.height(45.0, 0.7, 0.0) == pytest.approx(0.12 - 0.025)  # halfway out: D/2


def test_roughness_comes_from_the_surface_else_the_nodes_road() -> None:
    named = RoadProfile.build(RoadSurface(roughness_class="B", roughness_seed=2), "E", 9)
    assert named.roughness is not None
    assert (named.roughness.roughness_class, named.roughness.seed) == ("B", 2)
    fallback = RoadProfile.build(RoadSurface(), "E", 9)
    assert fallback.roughness is not None
    assert (fallback.roughness.roughness_class, fallback.roughness.seed) == ("E", 9)
    assert RoadProfile.build(RoadSurface(), None, 0).height(3.0, 4.0, 5.0) == 0.0  # smooth
