"""OpenSCENARIO files for the coverage tests (docs/openscenario.md's table against the
importer), written by `scenariogeneration` (OpenSCENARIO 1.3 unless a test asks for an older
minor version), and the table's quoted errors matched against the importer's.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.config import ConfigError
from carlaverse.traffic.openscenario import import_triggers
from carlaverse.traffic.openscenario_coverage import coverage

GT, LT, EQ = xosc.Rule.greaterThan, xosc.Rule.lessThan, xosc.Rule.equalTo
EUCLIDEAN = xosc.RelativeDistanceType.euclidianDistance
ROWS = {row.element: row for row in coverage()}
POINT = xosc.WorldPosition(10.0, 20.0, 3.0, 1.0)  # z and h are not read


def scenario(path: Path, *events: xosc.Event, init: xosc.Init | None = None,
             act_start: xosc.ValueTrigger | None = None, act_stop=None,
             parameters: xosc.ParameterDeclarations | None = None,
             minor: int = 3, actor: str = "car-1") -> Path:  # fmt: skip
    """A storyboard with these events in one maneuver of `actor` (beside `bike-1`), written by
    scenariogeneration as OpenSCENARIO 1.`minor` (older for what 1.3 deprecated and
    scenariogeneration refuses)."""
    box = xosc.BoundingBox(1.8, 4.5, 1.5, 1.3, 0, 0.75)
    front, rear = xosc.Axle(0.5, 0.8, 1.6, 2.9, 0.3), xosc.Axle(0, 0.8, 1.6, 0, 0.3)
    car = xosc.Vehicle("car", xosc.VehicleCategory.car, box, front, rear, 69, 10, 10)
    entities = xosc.Entities()
    for name in ("bike-1", actor):
        entities.add_scenario_object(name, car)
    maneuver = xosc.Maneuver("m")
    for event in events or [_plain_event()]:
        maneuver.add_event(event)
    group = xosc.ManeuverGroup("g")
    group.add_actor(actor)
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
