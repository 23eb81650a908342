"""The OpenSCENARIO coverage table (docs/openscenario.md) against the importer itself.

Every file here is written by `scenariogeneration` (OpenSCENARIO 1.3). The table's element list
is checked against the schemas read here with a plain regular expression (not the table's own
XSD walk); every supported or partly supported element is in one file the importer reads as
the table says; every refused condition and action, and every error message the table quotes,
is produced by a file built to hit it.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.config import ConfigError
from carlaverse.traffic.openscenario import import_triggers
from carlaverse.traffic.openscenario_coverage import (
    EXPLICIT,
    PARTLY,
    REFUSED,
    SUPPORTED,
    coverage,
    markdown,
    schema_files,
)
from carlaverse.traffic.trigger_spec import (
    Distance,
    Light,
    Message,
    Release,
    SetWeather,
    Speed,
    Ttc,
)

GT, LT, EQ = xosc.Rule.greaterThan, xosc.Rule.lessThan, xosc.Rule.equalTo
EUCLIDEAN = xosc.RelativeDistanceType.euclidianDistance
ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "openscenario.md"
BEGIN = re.compile(r"<!-- BEGIN GENERATED openscenario-coverage \(.*?\) -->\n")
END = "<!-- END GENERATED openscenario-coverage -->"
ROWS = {row.element: row for row in coverage()}
POINT = xosc.WorldPosition(10.0, 20.0, 3.0, 1.0)  # z and h are not read
DYNAMICS = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 1)


# --------------------------------------------------------------------------- building files


def scenario(path: Path, *events: xosc.Event, init: xosc.Init | None = None,
             act_start: xosc.ValueTrigger | None = None, act_stop=None,
             parameters: xosc.ParameterDeclarations | None = None,
             minor: int = 3) -> Path:  # fmt: skip
    """A storyboard with these events in one maneuver, written by scenariogeneration as
    OpenSCENARIO 1.`minor` (older for what 1.3 deprecated and scenariogeneration refuses)."""
    box = xosc.BoundingBox(1.8, 4.5, 1.5, 1.3, 0, 0.75)
    front, rear = xosc.Axle(0.5, 0.8, 1.6, 2.9, 0.3), xosc.Axle(0, 0.8, 1.6, 0, 0.3)
    car = xosc.Vehicle("car", xosc.VehicleCategory.car, box, front, rear, 69, 10, 10)
    entities = xosc.Entities()
    for name in ("bike-1", "car-1"):
        entities.add_scenario_object(name, car)
    maneuver = xosc.Maneuver("m")
    for event in events or [_plain_event()]:
        maneuver.add_event(event)
    group = xosc.ManeuverGroup("g")
    group.add_actor("car-1")
    group.add_maneuver(maneuver)
    start = act_start or xosc.ValueTrigger(
        "go", 0, xosc.ConditionEdge.none, xosc.SimulationTimeCondition(0.5, GT)
    )
    act = xosc.Act("act", start, act_stop)
    act.add_maneuver_group(group)
    story = xosc.Story("story")
    story.add_act(act)
    board = xosc.StoryBoard(init or xosc.Init())
    board.add_story(story)
    parameters = parameters or xosc.ParameterDeclarations()
    xosc.Scenario("study", "lab", parameters, entities, board, xosc.RoadNetwork(), xosc.Catalog(),
                  osc_minor_version=minor).write_xml(str(path))  # fmt: skip
    return path


def event(name: str, condition, *actions, entity: str = "bike-1", delay: float = 0,
          edge=xosc.ConditionEdge.rising, count: int = 1) -> xosc.Event:  # fmt: skip
    """An event on one condition (an entity condition for `entity`, else a value one)."""
    if entity:
        trigger = xosc.EntityTrigger(f"{name}-c", delay, edge, condition, entity)
    else:
        trigger = xosc.ValueTrigger(f"{name}-c", delay, edge, condition)
    out = xosc.Event(name, xosc.Priority.parallel, maxexecution=count)
    out.add_trigger(trigger)
    for i, action in enumerate(actions or [xosc.CustomCommandAction("carlaverse.message", "hi")]):
        out.add_action(f"{name}-a{i}", action)
    return out


def moving() -> xosc.SpeedCondition:
    return xosc.SpeedCondition(1, GT)


def _plain_event() -> xosc.Event:
    return event("plain", moving())


def value_event(name: str, condition, *actions, **kw) -> xosc.Event:
    return event(name, condition, *actions, entity="", **kw)


def environment(**weather_parts) -> xosc.Environment:
    weather = xosc.Weather(xosc.FractionalCloudCover.fourOktas, **weather_parts)
    noon = xosc.TimeOfDay(False, 2026, 11, 28, 12, 0, 0)
    return xosc.Environment(
        "env", noon, weather, xosc.RoadCondition(0.7, wetness=xosc.Wetness.moist)
    )


# --------------------------------------------------------------------------- the table itself


def test_the_docs_hold_the_generated_table() -> None:
    text = DOC.read_text()
    begin = BEGIN.search(text)
    assert begin and END in text, "docs/openscenario.md lost its generated markers"
    inside = text[begin.end() : text.index(END)]
    assert inside == markdown(list(ROWS.values())), (
        "stale: run python tools/openscenario_coverage.py --write docs/openscenario.md"
    )


def test_every_element_of_every_1x_schema_has_a_row() -> None:
    # the schemas' element names read with a regular expression, not the table's XSD walk
    names = set()
    for version, path in schema_files():
        assert version.startswith("1.")
        names |= set(re.findall(r'<xsd?:element name="(\w+)"', path.read_text()))
    assert [v for v, _ in schema_files()] == ["1.0", "1.1", "1.2", "1.3"]
    assert set(ROWS) == names and len(names) > 290


# --------------------------------------------------------------------------- what is read


def test_the_importer_s_own_list_is_supported_in_the_table() -> None:
    from carlaverse.traffic.openscenario import SUPPORTED as IMPORTER

    assert {name: ROWS[name].status for name in IMPORTER} == {
        name: SUPPORTED if name == "SimulationTimeCondition" else PARTLY for name in IMPORTER
    }


def _everything_supported(path: Path) -> Path:
    """One file with every supported or partly supported element, each used as the table
    says it is read (and with the parts it says are not read set to something)."""
    by_speed = event(
        "fast", xosc.SpeedCondition(2.0, GT, xosc.DirectionalDimension.lateral),
        xosc.TrafficSignalStateAction("J0", "GGrr"), count=2,
    )  # fmt: skip
    near = xosc.DistanceCondition(30, LT, POINT, freespace=False,
                                  distance_type=EUCLIDEAN)  # fmt: skip
    sun = xosc.Sun(1000, 1.0, 0.5)
    weather = dict(sun=sun, fog=xosc.Fog(250, xosc.BoundingBox(1, 1, 1, 0, 0, 0)),
                   precipitation=xosc.Precipitation(xosc.PrecipitationType.snow, 5.0))  # fmt: skip
    by_distance = event("near", near, xosc.EnvironmentAction(environment(**weather)))
    ttc = event("ttc", xosc.TimeToCollisionCondition(3.0, LT, freespace=True,
                                                     entity="car-1"))  # fmt: skip
    started = xosc.StoryboardElementState.startTransition
    after = value_event("after", xosc.StoryboardElementStateCondition(
        xosc.StoryboardElementType.event, "fast", started))  # fmt: skip
    at_time = value_event("at", xosc.SimulationTimeCondition(4, xosc.Rule.greaterOrEqual))
    parameters = xosc.ParameterDeclarations()
    parameters.add_parameter(xosc.Parameter("unused", xosc.ParameterType.double, "1.0"))
    return scenario(path, by_speed, by_distance, ttc, after, at_time,
                    act_stop=xosc.Trigger("stop"), parameters=parameters)  # fmt: skip


def _reach(path: Path) -> Path:
    """ReachPositionCondition, deprecated since 1.2, in a 1.1 file; its CustomCommandAction
    put in the UserDefinedAction the schema wants (scenariogeneration writes it bare)."""
    reach = event("reach", xosc.ReachPositionCondition(POINT, 2.0),
                  xosc.CustomCommandAction("carlaverse.release", "car-1"))  # fmt: skip
    tree = ET.parse(scenario(path, reach, minor=1))
    action = tree.find(".//Event/Action")
    command = action.find("CustomCommandAction")
    action.remove(command)
    ET.SubElement(action, "UserDefinedAction").append(command)
    tree.write(path)
    return path


def test_one_file_holds_every_supported_element_and_reads_as_the_table_says(
    tmp_path: Path,
) -> None:
    path, old = _everything_supported(tmp_path / "all.xosc"), _reach(tmp_path / "reach.xosc")
    tags = {e.tag for file in (path, old) for e in ET.parse(file).iter()}
    readable = {name for name, row in ROWS.items() if row.status in (SUPPORTED, PARTLY)}
    assert readable - tags == {"OpenScenario"}  # the root's other spelling: one root per file
    fast, near, ttc, after, at = import_triggers(path)
    (reach,) = import_triggers(old)
    act = "(t > 0.5) and "
    (speed_name, speed), = fast.measure.items()  # fmt: skip
    assert speed == Speed(actor="bike-1")  # direction not read
    assert fast.when == f"{act}((({speed_name} > 2.0)))" and fast.repeat  # count 2 repeats
    assert fast.actions == [Light(id="J0", state="GGrr")]
    (near_name, distance), = near.measure.items()  # fmt: skip
    assert distance == Distance(actor="bike-1", point=(10.0, 20.0))  # z, h not read
    assert near.when == f"{act}((({near_name} < 30.0)))" and not near.repeat
    (weather,) = near.actions
    assert isinstance(weather, SetWeather)
    # Sun: azimuth 1.0 rad, elevation 0.5 rad; Fog 250 m: 1 - 250/1000; snow 5 mm/h: 0.5 (type
    # not read); four oktas: 4/8; moist: 0.3 (friction not read); TimeOfDay not read
    assert weather.values() == pytest.approx({
        "sun_azimuth_deg": 57.29577951, "sun_altitude_deg": 28.64788976, "fog_density": 0.75,
        "precipitation": 0.5, "cloudiness": 0.5, "wetness": 0.3,
    })  # fmt: skip
    (reach_name, reached), = reach.measure.items()  # fmt: skip
    assert reached == Distance(actor="bike-1", point=(10.0, 20.0))
    assert reach.when == f"(t > 0.5) and ((({reach_name} < 2.0)))"
    assert reach.actions == [Release(npc="car-1")]
    (ttc_name, measure), = ttc.measure.items()  # fmt: skip
    assert measure == Ttc(actor="bike-1", other="car-1")
    assert ttc.when == f"{act}((({ttc_name} < 3.0)))" and ttc.actions == [Message(text="hi")]
    assert after.when == f"{act}((fired_fast > 0))"  # the state (startTransition) not read
    assert at.when == f"{act}((t >= 4.0))"


def test_triggering_entities_any_or_all(tmp_path: Path) -> None:
    speed = xosc.SpeedCondition(2.0, GT)
    for rule, joiner in ((xosc.TriggeringEntitiesRule.any, " or "),
                         (xosc.TriggeringEntitiesRule.all, " and ")):  # fmt: skip
        trigger = xosc.EntityTrigger("c", 0, xosc.ConditionEdge.rising, speed, "bike-1",
                                     triggeringrule=rule)  # fmt: skip
        trigger.add_triggering_entity("car-1")
        ev = xosc.Event("e", xosc.Priority.parallel)
        ev.add_trigger(trigger)
        ev.add_action("a", xosc.CustomCommandAction("carlaverse.message", "hi"))
        (imported,) = import_triggers(scenario(tmp_path / "rule.xosc", ev))
        a, b = imported.measure
        assert imported.when == f"(t > 0.5) and ((({a} > 2.0{joiner}{b} > 2.0)))"


# --------------------------------------------------------------------------- what is refused


def _private(action) -> Callable[[], xosc.Event]:
    return lambda: event("e", moving(), action)


def _global(action) -> Callable[[], xosc.Event]:
    return _private(action)


TRAFFIC = xosc.TrafficDefinition("t")
TRAFFIC.add_vehicle(xosc.VehicleCategory.car, 1.0)
TRAFFIC.add_controller(xosc.Controller("c", xosc.Properties()), 1.0)
# every condition and action the table refuses by its own name -> a file's event holding it
REFUSED_BUILDERS: dict[str, Callable[[], xosc.Event]] = {
    "EndOfRoadCondition": lambda: event("e", xosc.EndOfRoadCondition(1)),
    "CollisionCondition": lambda: event("e", xosc.CollisionCondition("car-1")),
    "OffroadCondition": lambda: event("e", xosc.OffroadCondition(1)),
    "TimeHeadwayCondition": lambda: event("e", xosc.TimeHeadwayCondition("car-1", 1, LT)),
    "AccelerationCondition": lambda: event("e", xosc.AccelerationCondition(1, GT)),
    "StandStillCondition": lambda: event("e", xosc.StandStillCondition(1)),
    "RelativeSpeedCondition": lambda: event("e", xosc.RelativeSpeedCondition(1, LT, "car-1")),
    "TraveledDistanceCondition": lambda: event("e", xosc.TraveledDistanceCondition(5)),
    "RelativeDistanceCondition": lambda: event("e", xosc.RelativeDistanceCondition(
        5, LT, EUCLIDEAN, "car-1")),
    "RelativeClearanceCondition": lambda: event("e", xosc.RelativeClearanceCondition(False, 5, 5)),
    "AngleCondition": lambda: event("e", xosc.AngleCondition(
        0.1, 0.1, xosc.AngleType.heading, xosc.CoordinateSystem.entity)),
    "RelativeAngleCondition": lambda: event("e", xosc.RelativeAngleCondition(
        0.1, 0.1, xosc.AngleType.heading, "car-1", xosc.CoordinateSystem.entity)),
    "ParameterCondition": lambda: value_event("e", xosc.ParameterCondition("p", 1, EQ)),
    "TimeOfDayCondition": lambda: value_event("e", xosc.TimeOfDayCondition(
        GT, 2026, 1, 1, 12, 0, 0)),
    "UserDefinedValueCondition": lambda: value_event("e", xosc.UserDefinedValueCondition(
        "u", 1, EQ)),
    "TrafficSignalCondition": lambda: value_event("e", xosc.TrafficSignalCondition("J0", "red")),
    "TrafficSignalControllerCondition": lambda: value_event(
        "e", xosc.TrafficSignalControllerCondition("ctl", "p1")),
    "VariableCondition": lambda: value_event("e", xosc.VariableCondition("v", 1, EQ)),
    "EntityAction": _global(xosc.DeleteEntityAction("car-1")),
    "SetMonitorAction": _global(xosc.SetMonitorAction("m", True)),
    "ParameterAction": _global(xosc.ParameterSetAction("p", 1)),
    "TrafficAction": _global(xosc.TrafficStopAction("t")),
    "VariableAction": _global(xosc.VariableSetAction("v", 1)),
    "TrafficSignalControllerAction": _global(xosc.TrafficSignalControllerAction("p1", "ctl")),
    "LongitudinalAction": _private(xosc.AbsoluteSpeedAction(10, DYNAMICS)),
    "LateralAction": _private(xosc.AbsoluteLaneChangeAction(1, DYNAMICS)),
    "VisibilityAction": _private(xosc.VisibilityAction(True, True, True)),
    "SynchronizeAction": _private(xosc.SynchronizeAction("car-1", POINT, POINT)),
    "ActivateControllerAction": _private(xosc.ActivateControllerAction(True, True)),
    "ControllerAction": _private(xosc.AssignControllerAction(
        xosc.ObjectController("oc", controller=xosc.Controller("c", xosc.Properties())))),
    "TeleportAction": _private(xosc.TeleportAction(POINT)),
    "RoutingAction": _private(xosc.AcquirePositionAction(POINT)),
    "AppearanceAction": _private(xosc.LightStateAction(
        xosc.VehicleLightType.brakeLights, xosc.LightMode.on)),
    "TrailerAction": _private(xosc.ConnectTrailerAction("trailer")),
}  # fmt: skip


# what scenariogeneration writes only in an older version: ParameterAction was replaced by
# VariableAction in 1.2; ActivateControllerAction moved into ControllerAction in 1.1
MINOR = {"ParameterAction": 1, "ActivateControllerAction": 0}


def templates(detail: str) -> list[str]:
    """The error messages a row quotes: its backticked texts of four words or more (the
    shorter ones are names: `t`, `speed`, `fired_<ref> > 0`)."""
    return [t for t in re.findall(r"`([^`]+)`", detail) if t.count(" ") >= 3]


def matches(template: str, message: str) -> bool:
    """`…` stands for any text, NAME for an event's or act's name."""
    pattern = re.escape(template).replace("NAME", "[^']*").replace("…", ".*")
    return re.fullmatch(pattern, message, flags=re.DOTALL) is not None


def refusal(path: Path) -> str:
    with pytest.raises(ConfigError) as caught:
        import_triggers(path)
    message = caught.value.detail
    assert "\n" not in message and str(caught.value) == f"{path}: {message}"  # one line
    return message


def test_every_refused_condition_and_action_is_built_here() -> None:
    # the rows whose status follows from the schema (a condition or action not known)
    own_message = {name for name, row in ROWS.items()
                   if row.status == REFUSED and name not in EXPLICIT
                   and row.detail.startswith("`event 'NAME': <")}  # fmt: skip
    assert set(REFUSED_BUILDERS) == own_message


@pytest.mark.parametrize("element", sorted(REFUSED_BUILDERS))
def test_a_refused_element_gives_the_stated_error(tmp_path: Path, element: str) -> None:
    path = scenario(tmp_path / "x.xosc", REFUSED_BUILDERS[element](), minor=MINOR.get(element, 3))
    message = refusal(path)
    (template,) = templates(ROWS[element].detail)
    assert matches(template, message), (template, message)
    assert matches(templates(ROWS["PrivateAction"].detail)[0], message) == message.startswith(
        "event 'e': <PrivateAction>"
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
    ("PrivateAction", lambda p: scenario(p, REFUSED_BUILDERS["TeleportAction"]())),
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
