"""What the road tells a driver, per lane of a SUMO network: lane changes and right of way.

- Lane changes: SUMO's lane attributes `changeLeft` / `changeRight` list the vehicle classes
  that may change from the lane to its left / right neighbour (absent: every class). We ask
  for passenger cars, as SUMO's own GUI does when it draws a solid or dashed line. sumolib
  (1.28) does not keep these attributes, so `read_change_rules` takes them from the file.
- Overtaking: a lane's `<neigh lane=…>` names the oncoming lane that may be used to overtake.
- Right of way at the lane's end, from its links' states and the junction's type (SUMO,
  "Networks/PlainXML", node types, and "Simulation/Intersections", link states):

  | link state / node type                    | `right_of_way`                          |
  |-------------------------------------------|-----------------------------------------|
  | a link controlled by a traffic light      | signal                                  |
  | `w` (allway_stop)                         | allway_stop                             |
  | `s` (priority_stop, minor road)           | stop                                    |
  | `Z` (zipper)                              | zipper                                  |
  | `=` (right_before_left/left_before_right) | right_before_left / left_before_right   |
  | node `priority`: the main road            | major                                   |
  | node `priority`: a minor road             | yield                                   |

  A road is minor at a priority junction when its edge priority is below the highest of the
  junction's approaches ("vehicles on a low-priority edge have to wait"), or, among equal
  priorities, when none of its links is major (`M`) while another approach's is. The second
  rule keeps a zebra crossing's approaches (all minor, they yield to pedestrians, not to a
  road) from being signed as a give-way.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

CHANGE_PARAMS = {"changeLeft": "carlaverse.changeLeft", "changeRight": "carlaverse.changeRight"}
CAR_CLASS = "passenger"  # the class whose lane changes decide a marking


def read_change_rules(path: Path, net: Any) -> None:
    """Copy the lanes' changeLeft/changeRight attributes into their params (sumolib skips them)."""
    for _, element in ET.iterparse(path):
        if element.tag == "lane" and ("changeLeft" in element.attrib or
                                      "changeRight" in element.attrib):  # fmt: skip
            lane = net.getLane(element.get("id"))
            for attribute, param in CHANGE_PARAMS.items():
                if attribute in element.attrib:
                    lane.setParam(param, element.get(attribute))
        if element.tag in ("edge", "connection", "junction"):
            element.clear()  # keep memory flat on large networks


def may_change(lane: Any, attribute: str) -> bool:
    """Whether a passenger car may change from `lane` to the left / right ('changeLeft'...)."""
    classes = lane.getParam(CHANGE_PARAMS[attribute])
    if classes is None:
        return True
    words = set(classes.split())
    return bool(words & {CAR_CLASS, "all"})


def right_of_way(lane: Any) -> str:
    """The rule at the lane's end for a vehicle arriving on it ("" for none)."""
    edge = lane.getEdge()
    links = lane.getOutgoing()
    if edge.getFunction() != "" or not links or not _is_vehicle_lane(lane):
        return ""
    states = {link.getState() for link in links}
    if any(link.getTLSID() for link in links):
        return "signal"
    for state, rule in (("w", "allway_stop"), ("s", "stop"), ("Z", "zipper")):
        if state in states:
            return rule
    node = edge.getToNode()
    if "=" in states:
        return "left_before_right" if node.getType() == "left_before_right" else "right_before_left"
    if node.getType() in ("priority", "priority_stop"):
        return "yield" if _is_minor(edge, node) else "major"
    return ""


def _is_vehicle_lane(lane: Any) -> bool:
    return bool(set(lane.getPermissions()) - {"pedestrian"})


def _is_minor(edge: Any, node: Any) -> bool:
    approaches = [e for e in node.getIncoming() if e.getFunction() == "" and _has_vehicle_lane(e)]
    if edge.getPriority() < max(e.getPriority() for e in approaches):
        return True
    others = [e for e in approaches if e is not edge]
    return not _has_major_link(edge) and any(_has_major_link(e) for e in others)


def _has_vehicle_lane(edge: Any) -> bool:
    return any(_is_vehicle_lane(lane) for lane in edge.getLanes())


def _has_major_link(edge: Any) -> bool:
    return any(
        link.getState() == "M"
        for lane in edge.getLanes()
        if _is_vehicle_lane(lane)
        for link in lane.getOutgoing()
    )
