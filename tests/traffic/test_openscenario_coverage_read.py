"""What the OpenSCENARIO coverage table (docs/openscenario.md) says is read: the importer's
own list is supported in the table, and one file (written by `scenariogeneration`) holds every
supported or partly supported element and is read as the table says.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.traffic.openscenario import import_triggers
from carlaverse.traffic.openscenario_coverage import PARTLY, SUPPORTED
from carlaverse.traffic.trigger_spec import (
    Distance,
    Light,
    Message,
    Release,
    SetWeather,
    Speed,
    Ttc,
)
from tests.traffic.openscenario_files import (
    EUCLIDEAN,
    GT,
    LT,
    POINT,
    ROWS,
    environment,
    event,
    scenario,
    value_event,
)


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
