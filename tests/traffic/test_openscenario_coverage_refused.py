"""The conditions and actions the OpenSCENARIO coverage table (docs/openscenario.md) refuses
by their own name (the importer does not know them): each is built here into a file written by
`scenariogeneration`, and the importer's one-line error is the one the table quotes.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.traffic.openscenario_coverage import EXPLICIT, REFUSED
from tests.traffic.openscenario_files import (
    EQ,
    EUCLIDEAN,
    GT,
    LT,
    POINT,
    ROWS,
    event,
    matches,
    moving,
    refusal,
    scenario,
    templates,
    value_event,
)

DYNAMICS = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 1)


def _private(action) -> Callable[[], xosc.Event]:
    return lambda: event("e", moving(), action)


def _global(action) -> Callable[[], xosc.Event]:
    return _private(action)


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
