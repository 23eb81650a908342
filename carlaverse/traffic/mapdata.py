"""The map reply (`authority/map`) built from a SUMO network with sumolib.

Every lane of the network goes in, internal junction lanes included, each with its centre
line, width and kind (road, sidewalk, bike, crossing, walkingarea, rail), its speed limit,
lane-change and overtaking rules, the right of way at its end and the lanes it leads to
(`lane_rules`); junction shapes and polygons (vegetation, water, buildings) become areas —
from the map's .poly.xml, or generated (`scenery`) when it has none; every traffic light
gets a position and, per link index of its
state string, the lane that link controls (the crossing itself for pedestrian signals, the
incoming lane otherwise).
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path
from typing import Any

from carlaverse.messages import SCHEMA_VERSION, MapArea, MapLane, MapLight, MapReply
from carlaverse.traffic.lane_rules import may_change, read_change_rules, right_of_way
from carlaverse.traffic.scenery import scenery
from carlaverse.traffic.sumo_tools import SumoMissingError

log = logging.getLogger(__name__)

# Vehicle classes worth telling renderers and audio apart; `allow` lists the ones a lane
# permits and is empty when it permits them all.
RELEVANT_CLASSES = (
    "passenger",
    "delivery",
    "truck",
    "bus",
    "motorcycle",
    "bicycle",
    "pedestrian",
    "tram",
    "rail",
)
RAIL_CLASSES = {"tram", "rail", "rail_urban", "rail_electric", "rail_fast"}
AREA_WORDS = {
    "water": ("water", "river", "lake", "sea", "riverbank", "pond", "canal", "reservoir"),
    "vegetation": (
        "forest",
        "wood",
        "park",
        "grass",
        "meadow",
        "garden",
        "scrub",
        "tree",
        "vegetation",
        "orchard",
        "vineyard",
        "farmland",
        "heath",
        "green",
    ),
    "building": ("building",),
}


def read_net(path: Path) -> Any:
    """The network as a sumolib object, with internal lanes and pedestrian connections (and
    the lane-change rules sumolib leaves out, as lane params: `lane_rules`)."""
    try:
        import sumolib
    except ImportError as exc:
        raise SumoMissingError(
            f"sumolib is missing ({exc}); pip install 'carlaverse[authority]'"
        ) from exc
    net = sumolib.net.readNet(str(path), withInternal=True, withPedestrianConnections=True)
    read_change_rules(path, net)
    return net


def build_map_reply(
    net: Any, name: str, polygons: Path | None = None, seed: int | None = None
) -> MapReply:
    """The reply for `net`; without polygons, generated scenery (seeded by `seed`, else by
    the map's name, so every build of a map gets the same buildings, parks and ponds)."""
    (xmin, ymin), (xmax, ymax) = net.getBBoxXY()
    bounds = (xmin, ymin, xmax, ymax)
    lanes, junctions = map_lanes(net), junction_areas(net)
    if polygons:
        areas = polygon_areas(polygons)
    else:
        areas = scenery(
            bounds, lanes, junctions, zlib.crc32(name.encode()) if seed is None else seed
        )
    return MapReply(SCHEMA_VERSION, name, bounds, lanes, junctions + areas, map_lights(net))


def map_lanes(net: Any) -> list[MapLane]:
    lanes = []
    for edge in net.getEdges(withInternal=True):
        function = edge.getFunction()
        for lane in edge.getLanes():
            permissions = set(lane.getPermissions())
            lanes.append(
                MapLane(
                    lane.getID(),
                    lane_kind(function, permissions),
                    lane.getWidth(),
                    [(x, y) for x, y, *_ in lane.getShape()],
                    _allow(permissions),
                    lane.getSpeed(),
                    may_change(lane, "changeLeft"),
                    may_change(lane, "changeRight"),
                    lane.getNeigh() or "",
                    right_of_way(lane),
                    [link.getToLane().getID() for link in lane.getOutgoing()],
                )
            )
    return lanes


def lane_kind(function: str, permissions: set[str]) -> str:
    if function in ("crossing", "walkingarea"):
        return function
    if permissions == {"pedestrian"}:
        return "sidewalk"
    if permissions == {"bicycle"}:
        return "bike"
    if permissions and permissions <= RAIL_CLASSES:
        return "rail"
    return "road"


def _allow(permissions: set[str]) -> list[str]:
    relevant = [c for c in RELEVANT_CLASSES if c in permissions]
    return [] if len(relevant) == len(RELEVANT_CLASSES) else relevant


def junction_areas(net: Any) -> list[MapArea]:
    areas = []
    for node in net.getNodes():
        shape = node.getShape()
        if node.getType() != "internal" and len(shape) >= 3:
            areas.append(MapArea(node.getID(), "junction", [(x, y) for x, y, *_ in shape]))
    return areas


def map_lights(net: Any) -> list[MapLight]:
    lights = []
    for tls in net.getTrafficLights():
        links: dict[int, str] = {}
        for in_lane, out_lane, index in tls.getConnections():
            crossing = out_lane.getEdge().getFunction() == "crossing"
            links[index] = (out_lane if crossing else in_lane).getID()
        size = max(links) + 1 if links else 0
        controlled = [links.get(i, "") for i in range(size)]
        lights.append(MapLight(tls.getID(), _light_position(net, tls), controlled))
    return lights


def _light_position(net: Any, tls: Any) -> tuple[float, float]:
    if net.hasNode(tls.getID()):
        x, y = net.getNode(tls.getID()).getCoord()[:2]
        return (x, y)
    ends = [c[0].getShape()[-1] for c in tls.getConnections()]
    if not ends:
        return (0.0, 0.0)
    return (sum(p[0] for p in ends) / len(ends), sum(p[1] for p in ends) / len(ends))


def polygon_areas(path: Path) -> list[MapArea]:
    """Vegetation, water and buildings from a SUMO .poly.xml; other polygons are skipped."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ValueError(f"{path}: cannot read polygons: {exc}") from exc
    areas: list[MapArea] = []
    for poly in root.iter("poly"):
        kind = area_kind(poly.get("type", ""))
        points = _points(poly.get("shape", ""))
        if kind and len(points) >= 3:
            areas.append(MapArea(poly.get("id", f"poly{len(areas)}"), kind, points))
    return areas


def area_kind(poly_type: str) -> str | None:
    lowered = poly_type.lower()
    for kind, words in AREA_WORDS.items():
        if any(word in lowered for word in words):
            return kind
    return None


def _points(shape: str) -> list[tuple[float, float]]:
    points = []
    for pair in shape.split():
        x, y, *_ = pair.split(",")
        points.append((float(x), float(y)))
    return points
