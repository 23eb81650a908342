"""Every error message the OpenSCENARIO coverage table (docs/openscenario.md) quotes for an
element the importer knows (`EXPLICIT`) is produced by a file built here to hit it, written by
`scenariogeneration`, and each case's error is one its row quotes.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.traffic.openscenario_coverage import EXPLICIT
from tests.traffic.openscenario_files import (
    EQ,
    EUCLIDEAN,
    GT,
    LT,
    POINT,
    ROWS,
    environment,
    event,
    matches,
    moving,
    refusal,
    scenario,
    templates,
    value_event,
)


def _without_start_trigger(path: Path) -> Path:
    tree = ET.parse(scenario(path, event("e", moving())))
    ev = tree.find(".//Event")
    ev.remove(ev.find("StartTrigger"))
    tree.write(path)
    return path


def _catalog(path: Path) -> Path:
    catalog = xosc.CatalogFile()
    catalog.create_catalog(str(path), "VehicleCatalog", "cars", "lab")
    box = xosc.BoundingBox(1.8, 4.5, 1.5, 1.3, 0, 0.75)
    axle = xosc.Axle(0.5, 0.8, 1.6, 2.9, 0.3)
    catalog.add_to_catalog(
        xosc.Vehicle("car", xosc.VehicleCategory.car, box, axle, axle, 69, 10, 10)
    )
    catalog.dump()
    return path


def _distribution(path: Path) -> Path:
    stochastic = xosc.Stochastic(10, 7)
    stochastic.add_distribution("speed", xosc.UniformDistribution(xosc.Range(5, 15)))
    xosc.ParameterValueDistribution("speeds", "lab", "study.xosc", stochastic).write_xml(str(path))
    return path


def _wind(path: Path) -> Path:
    env = environment(wind=xosc.Wind(0.5, 3.0))
    return scenario(path, event("e", moving(), xosc.EnvironmentAction(env)))


def _dome(path: Path) -> Path:
    tree = ET.parse(_wind(path))
    weather = tree.find(".//Weather")
    weather.remove(weather.find("Wind"))
    ET.SubElement(ET.SubElement(weather, "DomeImage"), "DomeFile", filepath="sky.hdr")
    tree.write(path)
    return path


def _parameter_reference(path: Path) -> Path:
    speed = xosc.SpeedCondition("$speed", GT)
    parameters = xosc.ParameterDeclarations()
    parameters.add_parameter(xosc.Parameter("speed", xosc.ParameterType.double, "2.0"))
    return scenario(path, event("e", speed), parameters=parameters)


def _position(path: Path, position) -> Path:
    return scenario(path, event("e", xosc.DistanceCondition(
        5, LT, position, freespace=False,
        distance_type=EUCLIDEAN)))  # fmt: skip


ROAD = xosc.RoadPosition(10, 0, 1)
# (the row whose quoted error it gives, a file built to hit it)
STATED_CASES: list[tuple[str, Callable[[Path], Path]]] = [
    ("OpenSCENARIO", _catalog),
    ("Catalog", _catalog),
    ("ParameterValueDistribution", _distribution),
    ("ParameterDeclarations", _parameter_reference),
    ("CatalogReference", lambda p: scenario(p, event("e", moving(),
        xosc.EnvironmentAction(xosc.CatalogReference("EnvironmentCatalog", "noon")))) ),
    ("Init", lambda p: scenario(p, init=_init_teleport())),
    ("Actions", lambda p: scenario(p, init=_init_teleport())),
    ("Act", lambda p: scenario(p, act_start=xosc.ValueTrigger(
        "go", 0, xosc.ConditionEdge.none, xosc.ParameterCondition("p", 1, EQ)))),
    ("StopTrigger", lambda p: scenario(p, act_stop=xosc.ValueTrigger(
        "stop", 0, xosc.ConditionEdge.rising, xosc.SimulationTimeCondition(9, GT),
        triggeringpoint="stop"))),
    ("Event", _without_start_trigger),
    ("Event", lambda p: scenario(p, event("twice", moving()), event("twice", moving()))),
    ("Condition", lambda p: scenario(p, event("e", moving(), delay=1))),
    ("Condition", lambda p: scenario(p, event("e", moving(),
                                              edge=xosc.ConditionEdge.falling))),
    ("DistanceCondition", lambda p: scenario(p, event("e", xosc.DistanceCondition(
        5, LT, POINT, freespace=True,
        distance_type=EUCLIDEAN)))),
    ("DistanceCondition", lambda p: scenario(p, event("e", xosc.DistanceCondition(
        5, LT, POINT, freespace=False,
        distance_type=xosc.RelativeDistanceType.lateral)))),
    ("StoryboardElementStateCondition", lambda p: scenario(p, value_event(
        "e", xosc.StoryboardElementStateCondition(xosc.StoryboardElementType.act, "act",
                                                  xosc.StoryboardElementState.endTransition)))),
    ("StoryboardElementStateCondition", lambda p: scenario(p, value_event(
        "e", xosc.StoryboardElementStateCondition(xosc.StoryboardElementType.event, "nowhere",
                                                  xosc.StoryboardElementState.endTransition)))),
    ("TimeToCollisionCondition", lambda p: scenario(p, event("e", xosc.TimeToCollisionCondition(
        3, LT, freespace=False, entity="car-1")))),
    ("TimeToCollisionConditionTarget", lambda p: scenario(p, event(
        "e", xosc.TimeToCollisionCondition(3, LT, freespace=True, position=POINT)))),
    ("Position", lambda p: _position(p, ROAD)),
    ("RoadPosition", lambda p: _position(p, ROAD)),
    ("LanePosition", lambda p: _position(p, xosc.LanePosition(10, 0, "-1", "1"))),
    ("RelativeWorldPosition", lambda p: _position(p, xosc.RelativeWorldPosition("car-1", 1, 1, 0))),
    ("RelativeObjectPosition", lambda p: _position(p, xosc.RelativeObjectPosition("car-1", 1, 1))),
    ("RelativeRoadPosition", lambda p: _position(p, xosc.RelativeRoadPosition(1, 1, "car-1"))),
    ("RelativeLanePosition", lambda p: _position(p, xosc.RelativeLanePosition(-1, "car-1", 0, 5))),
    ("GeoPosition", lambda p: _position(p, xosc.GeoPosition(48.1, 11.5))),
    ("RoutePosition", lambda p: _position(p, _route_position())),
    ("TrajectoryPosition", lambda p: _position(p, _trajectory_position())),
    ("Position", lambda p: scenario(p, event("e", xosc.ReachPositionCondition(ROAD, 2)),
                                                  minor=1)),
    ("CustomCommandAction", lambda p: scenario(p, event(
        "e", moving(), xosc.CustomCommandAction("esmini.print", "x")))),
    ("Weather", _wind),
    ("Wind", _wind),
    ("DomeImage", _dome),
    # the refused TeleportAction's file (test_openscenario_coverage_refused.py)
    ("PrivateAction", lambda p: scenario(p, event("e", moving(), xosc.TeleportAction(POINT)))),
]  # fmt: skip


def _init_teleport() -> xosc.Init:
    init = xosc.Init()
    init.add_init_action("car-1", xosc.TeleportAction(POINT))
    return init


def _route_position():
    route = xosc.Route("r")
    route.add_waypoint(POINT, xosc.RouteStrategy.shortest)
    route.add_waypoint(xosc.WorldPosition(50, 20), xosc.RouteStrategy.shortest)
    return xosc.RoutePositionOfCurrentEntity(route, "car-1")


def _trajectory_position():
    trajectory = xosc.Trajectory("t", False)
    trajectory.add_shape(xosc.Polyline([0, 1], [POINT, xosc.WorldPosition(50, 20)]))
    return xosc.TrajectoryPosition(trajectory, 5)


@pytest.mark.parametrize(("element", "build"), STATED_CASES,
                         ids=[f"{e}-{i}" for i, (e, _) in enumerate(STATED_CASES)])  # fmt: skip
def test_a_stated_refusal_is_the_importer_s_error(tmp_path: Path, element: str, build) -> None:
    message = refusal(build(tmp_path / "x.xosc"))
    stated = templates(ROWS[element].detail)
    assert any(matches(t, message) for t in stated), (element, stated, message)


def test_every_quoted_error_is_hit_by_a_case(tmp_path: Path) -> None:
    hit: set[tuple[str, str]] = set()
    for i, (element, build) in enumerate(STATED_CASES):
        message = refusal(build(tmp_path / f"x{i}.xosc"))
        hit |= {(element, t) for t in templates(ROWS[element].detail) if matches(t, message)}
    quoted = {(name, t) for name in EXPLICIT for t in templates(EXPLICIT[name][1])}
    assert quoted - hit == set()
