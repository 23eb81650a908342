"""The map's lane rules through the real SUMO tool chain: plain XML → netconvert → sumolib →
MapReply, and back through the wire codec.

The network is a street W–P–S–A–T–E with a side road into each of P, S, A and T. Junction
types are SUMO's documented ones ("Networks/PlainXML", node types): at `priority` P the side
road (edge priority 1 against the main road's 3) must give way; at `priority_stop` S the side
road must stop; at `allway_stop` A everyone must stop; T is a traffic light. What each
approach must get follows from those statements alone, as do the speeds, lane-change
permissions and the oncoming lane written into the edge file.
"""

from __future__ import annotations

import pytest

from carlaverse.messages import MAP, MapLane
from carlaverse.traffic.mapdata import build_map_reply, read_net
from carlaverse.traffic.netbuild import build_map
from carlaverse.traffic.scenario import load_scenario

NODES = """<nodes>
  <node id="W" x="-200" y="0" type="priority"/>
  <node id="P" x="0" y="0" type="priority"/>
  <node id="S" x="200" y="0" type="priority_stop"/>
  <node id="A" x="400" y="0" type="allway_stop"/>
  <node id="T" x="600" y="0" type="traffic_light"/>
  <node id="E" x="800" y="0" type="priority"/>
  <node id="PN" x="0" y="150" type="priority"/>
  <node id="SN" x="200" y="150" type="priority"/>
  <node id="AN" x="400" y="150" type="priority"/>
  <node id="TN" x="600" y="150" type="priority"/>
</nodes>
"""
# WP: two lanes east, cars may not leave its right lane to the left (changeLeft lists only
# emergency vehicles); its left lane may overtake through PW's left lane (neigh).
EDGES = """<edges>
  <edge id="WP" from="W" to="P" numLanes="2" speed="13.89" priority="3">
    <lane index="0" changeLeft="emergency"/>
    <lane index="1"><neigh lane="PW_1"/></lane>
  </edge>
  <edge id="PW" from="P" to="W" numLanes="2" speed="13.89" priority="3">
    <lane index="1"><neigh lane="WP_1"/></lane>
  </edge>
  <edge id="PS" from="P" to="S" speed="8.33" priority="3"/>
  <edge id="SP" from="S" to="P" speed="8.33" priority="3"/>
  <edge id="SA" from="S" to="A" speed="8.33" priority="3"/>
  <edge id="AS" from="A" to="S" speed="8.33" priority="3"/>
  <edge id="AT" from="A" to="T" speed="13.89" priority="3"/>
  <edge id="TA" from="T" to="A" speed="13.89" priority="3"/>
  <edge id="TE" from="T" to="E" speed="22.22" priority="3"/>
  <edge id="ET" from="E" to="T" speed="22.22" priority="3"/>
  <edge id="PNP" from="PN" to="P" speed="8.33" priority="1"/>
  <edge id="SNS" from="SN" to="S" speed="8.33" priority="1"/>
  <edge id="ANA" from="AN" to="A" speed="8.33" priority="1"/>
  <edge id="TNT" from="TN" to="T" speed="8.33" priority="1"/>
</edges>
"""
SCENARIO = """name: lane-rules
map:
  plain: {nodes: rules.nod.xml, edges: rules.edg.xml}
"""


@pytest.fixture(scope="module")
def lanes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, MapLane]:
    folder = tmp_path_factory.mktemp("lane-rules")
    (folder / "rules.nod.xml").write_text(NODES, encoding="utf-8")
    (folder / "rules.edg.xml").write_text(EDGES, encoding="utf-8")
    (folder / "rules.yaml").write_text(SCENARIO, encoding="utf-8")
    built = build_map(load_scenario(folder / "rules.yaml"), folder / "cache")
    reply = MAP.decode(MAP.encode(build_map_reply(read_net(built.net), "lane-rules")))
    return {lane.id: lane for lane in reply.lanes}


@pytest.mark.parametrize(
    ("lane", "rule"),
    [
        ("PNP_0", "yield"),  # the side road at priority junction P
        ("WP_0", "major"),  # the main road there
        ("SP_0", "major"),
        ("SNS_0", "stop"),  # the side road at priority_stop S
        ("PS_0", "major"),  # the main road there does not stop
        ("ANA_0", "allway_stop"),  # all three approaches of A
        ("SA_0", "allway_stop"),
        ("TA_0", "allway_stop"),
        ("TNT_0", "signal"),  # every approach of the light T
        ("AT_0", "signal"),
        ("ET_0", "signal"),
        ("TE_0", ""),  # ends at a dead end
    ],
)
def test_right_of_way_follows_the_junction_type(lanes: dict[str, MapLane], lane: str,
                                                rule: str) -> None:  # fmt: skip
    assert lanes[lane].right_of_way == rule


def test_speed_lane_changes_overtaking_and_successors(lanes: dict[str, MapLane]) -> None:
    assert lanes["PS_0"].speed == pytest.approx(8.33)
    assert lanes["TE_0"].speed == pytest.approx(22.22)
    right, left = lanes["WP_0"], lanes["WP_1"]
    assert (right.change_left, right.change_right) == (False, True)  # emergency only
    assert (left.change_left, left.change_right) == (True, True)  # no changeLeft: everyone
    assert left.opposite == "PW_1" and right.opposite == ""
    # straight on through each junction; the side road turns onto the main road
    assert "PS_0" in set(lanes["WP_0"].successors) | set(lanes["WP_1"].successors)
    assert "SA_0" in lanes["PS_0"].successors and "TE_0" in lanes["AT_0"].successors
    assert {"PW_0", "PW_1", "PS_0"} & set(lanes["PNP_0"].successors)
