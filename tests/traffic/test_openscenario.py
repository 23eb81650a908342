"""OpenSCENARIO storyboards written by `scenariogeneration` become scenario triggers."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from scenariogeneration import xosc

from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.config import ConfigError
from carlaverse.messages import Notice, TriggerFired
from carlaverse.traffic.openscenario import import_triggers
from carlaverse.traffic.scenario import load_scenario
from carlaverse.traffic.trigger_spec import Distance, Message, Release, Speed
from tests.traffic.helpers import (
    CROSSING_CONFLICT,
    CROSSING_MAP,
    T0,
    TICK_S,
    domain_of,
    ego_track,
    net_cache,
    pose,
    write_scenario,
)
from tests.traffic.openscenario_files import scenario

__all__ = ["net_cache"]  # a fixture, imported for pytest
CONFLICT = CROSSING_CONFLICT


def _write(path: Path, *events: xosc.Event) -> Path:
    """A storyboard with these events for the car that waits at the conflict (OpenSCENARIO 1.3)."""
    return scenario(path, *events, actor="waiting-car")


def _pull_out() -> xosc.Event:
    within = xosc.DistanceCondition(
        30, xosc.Rule.lessThan, xosc.WorldPosition(*CONFLICT), freespace=False,
        distance_type=xosc.RelativeDistanceType.euclidianDistance,
    )  # fmt: skip
    near = xosc.EntityTrigger("near", 0, xosc.ConditionEdge.rising, within, "bike-1")
    faster = xosc.SpeedCondition(2.0, xosc.Rule.greaterThan)
    moving = xosc.EntityTrigger("moving", 0, xosc.ConditionEdge.none, faster, "bike-1")
    group = xosc.ConditionGroup()
    group.add_condition(near)
    group.add_condition(moving)
    trigger = xosc.Trigger()
    trigger.add_conditiongroup(group)
    event = xosc.Event("pull out", xosc.Priority.override)
    event.add_trigger(trigger)
    event.add_action("go", xosc.CustomCommandAction("carlaverse.release", "waiting-car"))
    event.add_action("warn", xosc.CustomCommandAction("carlaverse.message", "Car ahead"))
    return event


def _rain() -> xosc.Event:
    after = xosc.ValueTrigger("after", 0, xosc.ConditionEdge.none,
                              xosc.StoryboardElementStateCondition(
                                  xosc.StoryboardElementType.event, "pull out",
                                  xosc.StoryboardElementState.endTransition))  # fmt: skip
    rain = xosc.Precipitation(xosc.PrecipitationType.rain, 5.0)  # [mm/h]
    sun = xosc.Sun(1000, math.radians(90), math.radians(30))
    cover = xosc.FractionalCloudCover.sixOktas
    weather = xosc.Weather(cover, sun=sun, fog=xosc.Fog(250), precipitation=rain)
    road = xosc.RoadCondition(0.6, wetness=xosc.Wetness.wetWithPuddles)
    noon = xosc.TimeOfDay(False, 2026, 11, 23, 12, 0, 0)
    environment = xosc.Environment("wet", noon, weather, road)
    event = xosc.Event("rain", xosc.Priority.override)
    event.add_trigger(after)
    event.add_action("rain", xosc.EnvironmentAction(environment))
    return event


def test_events_become_triggers_with_their_conditions_and_actions(tmp_path: Path) -> None:
    pull_out, rain = import_triggers(_write(tmp_path / "study.xosc", _pull_out(), _rain()))
    assert pull_out.id == "pull_out"
    (near, near_m), (moving, moving_m) = pull_out.measure.items()
    assert near_m == Distance(actor="bike-1", point=CONFLICT)
    assert moving_m == Speed(actor="bike-1")
    assert pull_out.when == f"(t > 0.5) and ((({near} < 30.0) and ({moving} > 2.0)))"
    assert pull_out.actions == [Release(npc="waiting-car"), Message(text="Car ahead")]
    assert rain.when == "(t > 0.5) and ((fired_pull_out > 0))"
    (weather,) = rain.actions
    assert weather.values() == pytest.approx(
        {"sun_azimuth_deg": 90, "sun_altitude_deg": 30, "fog_density": 0.75,
         "precipitation": 0.5, "cloudiness": 0.75, "wetness": 0.6}
    )  # fmt: skip


def test_an_imported_event_fires_in_real_sumo(tmp_path: Path, net_cache) -> None:
    _write(tmp_path / "study.xosc", _pull_out())
    scenario = write_scenario(tmp_path, f"""{CROSSING_MAP}
traffic:
  vehicles: {{count: 0}}
  pedestrians: {{count: 0}}
  scripted_vehicles:
    - {{id: waiting-car, edges: [ZC, CE], depart_pos_m: 5, stop: {{edge: ZC, pos_m: 30}}}}
openscenario: study.xosc
""")  # fmt: skip
    track = ego_track("bike-1", actor_kind="bicycle", kind="bike")
    out = MemoryOutbox()
    with domain_of(scenario, net_cache) as domain:
        for k in range(round(12.0 / TICK_S)):
            t = T0 + k * TICK_S
            y = CONFLICT[1] - 60 + 5.0 * (t - T0)  # 5 m/s north: within 30 m after 6 s
            track.last_pose = pose(t, CONFLICT[0], y, math.pi / 2, 5.0)
            domain.tick(t, {"bike-1": track}, out)
    (fired,) = [e for e in out.events if isinstance(e, TriggerFired)]
    assert fired.trigger_id == "pull_out"
    assert fired.t == pytest.approx(T0 + 6.0, abs=2 * TICK_S)
    assert fired.actions == ["release waiting-car", "message to everyone"]
    assert [e.text for e in out.events if isinstance(e, Notice)] == ["Car ahead"]


def test_an_unsupported_element_is_refused_by_name(tmp_path: Path) -> None:
    event = _pull_out()
    dynamics = xosc.TransitionDynamics(
        xosc.DynamicsShapes.sinusoidal, xosc.DynamicsDimension.time, 2
    )
    event.add_action("swerve", xosc.AbsoluteLaneChangeAction(1, dynamics))
    path = _write(tmp_path / "study.xosc", event)
    with pytest.raises(
        ConfigError,
        match=r"study.xosc: event 'pull out': <PrivateAction><LateralAction><LaneChangeAction>",
    ):
        import_triggers(path)
    scenario = write_scenario(tmp_path, f"{CROSSING_MAP}\nopenscenario: study.xosc\n")
    with pytest.raises(ConfigError, match="LaneChangeAction"):
        load_scenario(scenario)


def _edited(path: Path, xpath: str, attribute: str, value: str | None) -> Path:
    """The storyboard at `path` with `attribute` of the element at `xpath` set, or removed
    when `value` is None: an input scenariogeneration would not write, as a hand edit can."""
    tree = ET.parse(path)
    element = tree.getroot().find(xpath)
    assert element is not None, xpath
    if value is None:
        del element.attrib[attribute]
    else:
        element.set(attribute, value)
    tree.write(path)
    return path


@pytest.mark.parametrize(
    ("value", "said"),
    [(None, "<SpeedCondition> has no value"), ("fast", "<SpeedCondition> has value 'fast'")],
)
def test_a_condition_without_its_number_is_one_config_error(
    tmp_path: Path, value: str | None, said: str
) -> None:
    # OpenSCENARIO requires SpeedCondition's `value` (a double); a file without one, or with
    # a word there, is refused naming file, event, element and attribute (it was a TypeError
    # or ValueError out of float(), with no file named).
    path = _write(tmp_path / "study.xosc", _pull_out())
    _edited(path, ".//SpeedCondition", "value", value)
    with pytest.raises(ConfigError, match=rf"study.xosc: event 'pull out': {said}"):
        import_triggers(path)


def test_an_unknown_road_wetness_is_refused_by_name(tmp_path: Path) -> None:
    # Wetness is an enumeration (dry, moist, wetWithPuddles, ...): a value outside it is
    # refused as an unknown cloud cover is (it was a KeyError).
    path = _write(tmp_path / "study.xosc", _pull_out(), _rain())
    _edited(path, ".//RoadCondition", "wetness", "soggy")
    with pytest.raises(ConfigError, match=r"study.xosc: event 'rain': road wetness 'soggy'"):
        import_triggers(path)


def test_an_entity_condition_without_its_entities_is_refused_by_name(tmp_path: Path) -> None:
    # A ByEntityCondition must say whose speed or distance it reads (TriggeringEntities); one
    # without is refused naming the condition (it was an AttributeError on None).
    path = _write(tmp_path / "study.xosc", _pull_out())
    tree = ET.parse(path)
    for by_entity in tree.getroot().iterfind(".//ByEntityCondition"):
        entities = by_entity.find("TriggeringEntities")
        assert entities is not None
        by_entity.remove(entities)
    tree.write(path)
    with pytest.raises(ConfigError, match=r"study.xosc: event 'pull out': <\w+Condition>"):
        import_triggers(path)
