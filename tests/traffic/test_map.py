"""The map reply: every lane of the network, junctions, lights and areas, in the wire schema."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from carlaverse.messages import MAP
from carlaverse.traffic.mapdata import area_kind, polygon_areas
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario
from tests.traffic.helpers import domain_of


@pytest.mark.parametrize("name", ["town", "crossing", "ring"])
def test_every_lane_is_in_the_reply_and_it_decodes(name: str, net_cache: Path) -> None:
    net_file = build_map(load_scenario(name), net_cache).net
    lanes_in_net = {lane.get("id") for lane in ET.parse(net_file).getroot().iter("lane")}
    with domain_of(name, net_cache) as domain:
        reply = domain.map_reply()
        readings = {r.id: r for r in domain.engine.light_readings()}
    decoded = MAP.decode(MAP.encode(reply))
    assert decoded == reply
    assert {lane.id for lane in decoded.lanes} == lanes_in_net
    assert all(lane.width > 0 and len(lane.centerline) >= 2 for lane in decoded.lanes)
    kinds = {lane.kind for lane in decoded.lanes}
    assert {"road", "sidewalk"} <= kinds
    xmin, ymin, xmax, ymax = decoded.bounds
    assert xmin < xmax and ymin < ymax
    assert {light.id for light in decoded.lights} == set(readings)
    for light in decoded.lights:
        assert len(light.controlled_lanes) == len(readings[light.id].state)  # one per link
        assert set(light.controlled_lanes) <= lanes_in_net


def test_town_and_crossing_have_crossings_walking_areas_and_junctions(net_cache: Path) -> None:
    with domain_of("crossing", net_cache) as domain:
        reply = domain.map_reply()
    kinds = {lane.kind for lane in reply.lanes}
    assert {"road", "sidewalk", "bike", "crossing", "walkingarea"} <= kinds
    zebra = next(lane for lane in reply.lanes if lane.id == ":Z_c0_0")
    assert zebra.kind == "crossing" and zebra.allow == ["pedestrian"]
    assert {a.id for a in reply.areas if a.kind == "junction"} >= {"C", "Z"}
    (light,) = reply.lights
    assert any(lane.startswith(":C_c") for lane in light.controlled_lanes)  # pedestrian signals


POLYS = """<additional>
    <poly id="wood" type="landuse.forest" shape="0,0 10,0 10,10 0,10"/>
    <poly id="pond" type="natural.water" shape="20,0 30,0 25,8"/>
    <poly id="house" type="building.yes" shape="40,0 45,0 45,5 40,5"/>
    <poly id="sign" type="amenity.bench" shape="50,0 51,0 51,1"/>
</additional>"""


def test_polygons_become_vegetation_water_and_building_areas(tmp_path: Path) -> None:
    path = tmp_path / "areas.poly.xml"
    path.write_text(POLYS, encoding="utf-8")
    areas = {a.id: a for a in polygon_areas(path)}
    assert {k: a.kind for k, a in areas.items()} == {
        "wood": "vegetation", "pond": "water", "house": "building"
    }  # fmt: skip
    assert areas["pond"].polygon == [(20.0, 0.0), (30.0, 0.0), (25.0, 8.0)]
    assert area_kind("leisure.park") == "vegetation" and area_kind("highway.primary") is None


def test_the_towns_two_way_streets_pair_their_oncoming_lanes(net_cache: Path) -> None:
    """A town street may be overtaken on, so its centre line is dashed (render/scene_markings
    dashes it where a lane has an `opposite`): each road lane's oncoming partner is the
    innermost lane of the edge running the other way between the same two junctions, as the
    network file itself says (read here with ElementTree, not the project's reader)."""
    net_file = build_map(load_scenario("town"), net_cache).net
    root = ET.parse(net_file).getroot()
    ends, innermost = {}, {}
    for edge in root.iter("edge"):
        if edge.get("function") == "internal":
            continue
        ends[edge.get("id")] = (edge.get("from"), edge.get("to"))
        # the sidewalk (allow="pedestrian") and any bike lane are not paired with oncoming lanes
        lanes = [lane for lane in edge.iter("lane")
                 if lane.get("allow") not in ("pedestrian", "bicycle")]  # fmt: skip
        if lanes:
            inner = max(lanes, key=lambda lane: int(lane.get("index")))
            innermost[edge.get("id")] = inner.get("id")
    by_ends = {pair: edge for edge, pair in ends.items()}
    expected = {}
    for edge, (start, end) in ends.items():
        back = by_ends.get((end, start))
        if edge in innermost and back in innermost:
            expected[innermost[edge]] = innermost[back]
    assert len(expected) >= 40  # the 3 x 3 grid's streets, both ways
    with domain_of("town", net_cache) as domain:
        opposite = {lane.id: lane.opposite for lane in domain.map_reply().lanes}
    assert {lane: opposite[lane] for lane in expected} == expected
