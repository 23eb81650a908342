"""OpenSCENARIO (.xosc) events as scenario triggers, for the subset that maps onto them.

A study designed in an OpenSCENARIO tool keeps its storyboard: every `Event` becomes one
trigger, its `StartTrigger` the condition (condition groups OR-ed, conditions within a group
AND-ed), its actions the trigger's actions. Actors are referenced by name: an entity called
`bike-1` is the participant `bike-1`, an NPC's entity name is its NPC id. What does not map
is refused with the element's name and where it is; nothing is silently dropped. The
supported elements are listed in `SUPPORTED` (and in README.md); every element of the 1.x
schemas, with what is read of it, in docs/openscenario.md (`openscenario_coverage`):

    carlaverse scenario: openscenario: study.xosc    # relative to the scenario file
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from carlaverse.config import ConfigError, convert
from carlaverse.traffic.trigger_spec import TriggerSpec

SUPPORTED = {
    "SimulationTimeCondition": "t compared with value",
    "StoryboardElementStateCondition": "another event fired (fired_<event> > 0)",
    "SpeedCondition": "speed measure",
    "DistanceCondition": "distance measure to a WorldPosition (freespace false, euclidean)",
    "ReachPositionCondition": "distance to a WorldPosition < tolerance",
    "TimeToCollisionCondition": "ttc measure with an entity (freespace true: footprints)",
    "TrafficSignalStateAction": "light action (state in SUMO link characters)",
    "EnvironmentAction": "weather action (Sun, Fog, Precipitation, RoadCondition wetness)",
    "CustomCommandAction": "type carlaverse.message (text) or carlaverse.release (NPC id)",
}
RULES = {
    "greaterThan": ">", "lessThan": "<", "equalTo": "==", "greaterOrEqual": ">=",
    "lessOrEqual": "<=", "notEqualTo": "!=",
}  # fmt: skip
WETNESS = {"dry": 0.0, "moist": 0.3, "wetWithPuddles": 0.6, "lowFlooded": 0.8, "highFlooded": 1.0}
OKTAS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight")
CLOUDS = {f"{n}Oktas": i / 8 for i, n in enumerate(OKTAS)} | {"nineOktas": 1.0}  # 1.2
CLOUDS |= {"free": 0.0, "cloudy": 0.5, "overcast": 1.0, "rainy": 1.0, "skyOff": 0.0}  # 1.0
RAIN_FULL_MM_H = 10.0  # [mm/h] heavy rain: precipitation 1.0
CLEAR_VISIBILITY_M = 1000.0  # [m] fog visual range at which fog density is 0
# Containers walked through on the way to what is supported.
_WRAPPERS = {"GlobalAction", "InfrastructureAction", "TrafficSignalAction", "UserDefinedAction",
             "ByEntityCondition", "ByValueCondition", "EntityCondition"}  # fmt: skip


class Refused(ValueError):
    """An element outside the supported subset; the message names it and where it is."""


def import_triggers(path: Path) -> list[TriggerSpec]:
    """Every event of an .xosc storyboard as a trigger (ConfigError naming file and element)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ConfigError(str(path), f"cannot read OpenSCENARIO file: {exc}") from exc
    try:
        _refuse_outside_the_events(root)
        triggers = [_event(e, act_time) for e, act_time in _events(root)]
        _refuse_twins(triggers)
    except Refused as exc:
        raise ConfigError(str(path), str(exc)) from exc
    except ValueError as exc:  # a number that is none (float("fast")): the element is named
        raise ConfigError(str(path), f"bad value in the storyboard: {exc}") from exc
    return [convert(t, TriggerSpec, str(path)) for t in triggers]


def _refuse_outside_the_events(root: ET.Element) -> None:
    """What would change the storyboard's meaning outside its events is refused, not skipped."""
    board = root.find("./Storyboard")
    if board is None:
        raise Refused(
            f"<{root.tag}> holds no <Storyboard>: a catalog or a parameter distribution is "
            "not a scenario"
        )
    init = board.find("./Init/Actions")
    if init is not None and len(init):
        raise Refused(
            f"Init action <{init[0].tag}> is not supported: the scenario YAML places actors"
        )
    events = {event.get("name") for event in board.iter("Event")}
    for element in board.iter():
        _refuse_element(element)
        ref = element.get("storyboardElementRef")
        if element.get("storyboardElementType") == "event" and ref not in events:
            raise Refused(f"StoryboardElementStateCondition refers to {ref!r}, no event of this "
                          "storyboard")  # fmt: skip


def _refuse_twins(triggers: list[dict[str, Any]]) -> None:
    """Each event is a trigger named after it: two events may not share a name."""
    ids = [t["id"] for t in triggers]
    twins = sorted({i for i in ids if ids.count(i) > 1})
    if twins:
        raise Refused(f"events named {twins[0]!r} (as a trigger id) more than once: name each "
                      "event apart")  # fmt: skip


def _refuse_element(element: ET.Element) -> None:
    if element.tag == "StopTrigger" and len(element):
        raise Refused(
            "a StopTrigger with conditions is not supported: a session ends by its --duration "
            "or Ctrl-C"
        )
    if element.tag == "CatalogReference":
        raise Refused(
            f"<CatalogReference catalogName={element.get('catalogName')!r}> is not "
            "supported: write the element out in the storyboard"
        )
    for attribute, value in element.attrib.items():
        if value.startswith("$"):
            raise Refused(
                f"<{element.tag} {attribute}={value!r}>: parameter references and "
                "expressions are not supported: write the value"
            )


def _events(root: ET.Element) -> Iterator[tuple[ET.Element, str]]:
    for act in root.iterfind("./Storyboard/Story/Act"):
        act_time = ""
        start = act.find("StartTrigger")
        if start is not None and len(start):
            act_time = _act_start(act, start)
        for event in act.iterfind("./ManeuverGroup/Maneuver/Event"):
            yield event, act_time


def _act_start(act: ET.Element, start: ET.Element) -> str:
    conditions = start.findall(".//SimulationTimeCondition")
    if len(conditions) != len(start.findall(".//Condition")):
        raise Refused(f"Act {act.get('name')!r}: only a SimulationTimeCondition may start an Act")
    return " or ".join(
        f"t {RULES[c.get('rule', '')]} {float(c.get('value', 0))}" for c in conditions
    )


def _number(ev: _Event, element: ET.Element, name: str) -> float:
    """An attribute the schema requires to be a number; Refused naming it when not."""
    text = element.get(name)
    where = f"event {ev.name!r}: <{element.tag}>"
    if text is None:
        raise Refused(f"{where} has no {name}")
    try:
        return float(text)
    except ValueError:
        raise Refused(f"{where} has {name} {text!r}, not a number") from None


class _Event:
    """One event being translated: its measurements and condition text."""

    def __init__(self, element: ET.Element) -> None:
        self.name = element.get("name", "")
        self.id = _identifier(self.name)
        self.measure: dict[str, dict[str, Any]] = {}

    def refuse(self, what: str) -> Refused:
        return Refused(f"event {self.name!r}: {what} is not supported; supported: "
                       f"{', '.join(SUPPORTED)}")  # fmt: skip

    def add_measure(self, kind: str, actor: str, **fields: Any) -> str:
        name = _identifier(f"{kind}_{actor}_{len(self.measure) + 1}")
        self.measure[name] = {"type": kind, "actor": actor, **fields}
        return name


def _event(element: ET.Element, act_time: str) -> dict[str, Any]:
    ev = _Event(element)
    start = element.find("StartTrigger")
    if start is None or not len(start):
        raise ev.refuse("an event without a StartTrigger")
    groups = [_group(ev, g) for g in start.iterfind("ConditionGroup")]
    when = " or ".join(f"({g})" for g in groups)
    if act_time:
        when = f"({act_time}) and ({when})"
    count = int(element.get("maximumExecutionCount", "1"))
    actions = [_action(ev, a) for a in element.iterfind("Action")]
    return {"id": ev.id, "when": when, "measure": ev.measure, "actions": actions,
            "repeat": count > 1}  # fmt: skip


def _group(ev: _Event, group: ET.Element) -> str:
    return " and ".join(_condition(ev, c) for c in group.iterfind("Condition"))


def _condition(ev: _Event, c: ET.Element) -> str:
    if float(c.get("delay", "0")) != 0:
        raise ev.refuse(f"condition {c.get('name')!r} with a delay")
    if c.get("conditionEdge", "none") not in ("rising", "none"):
        raise ev.refuse(f"conditionEdge {c.get('conditionEdge')!r} (triggers fire on rising)")
    body = _unwrap(c)
    if body.tag == "SimulationTimeCondition":
        return f"t {_rule(ev, body)} {float(body.get('value', 0))}"
    if body.tag == "StoryboardElementStateCondition":
        kind = body.get("storyboardElementType", "event")
        if kind != "event":  # fired_<name> counts events' triggers only
            raise ev.refuse(f"StoryboardElementStateCondition on a {kind} (events only)")
        return f"fired_{_identifier(body.get('storyboardElementRef', ''))} > 0"
    triggering = c.find(".//TriggeringEntities")
    if triggering is None:  # a value condition other than the two above
        raise ev.refuse(_chain(body))
    actors = [e.get("entityRef", "") for e in triggering.iterfind("EntityRef")]
    joiner = " and " if triggering.get("triggeringEntitiesRule") == "all" else " or "
    return "(" + joiner.join(_entity_condition(ev, body, actor) for actor in actors) + ")"


def _entity_condition(ev: _Event, body: ET.Element, actor: str) -> str:
    if body.tag == "SpeedCondition":
        return f"{ev.add_measure('speed', actor)} {_rule(ev, body)} {_number(ev, body, 'value')}"
    if body.tag == "ReachPositionCondition":
        name = ev.add_measure("distance", actor, point=_world_position(ev, body))
        return f"{name} < {_number(ev, body, 'tolerance')}"
    if body.tag == "DistanceCondition":
        if body.get("freespace", "false") != "false":
            raise ev.refuse("DistanceCondition with freespace true (centres only)")
        if body.get("relativeDistanceType", "euclidianDistance") not in (
            "euclidianDistance",
            "euclidean",
        ):
            raise ev.refuse(
                f"DistanceCondition relativeDistanceType {body.get('relativeDistanceType')!r}"
            )
        name = ev.add_measure("distance", actor, point=_world_position(ev, body))
        return f"{name} {_rule(ev, body)} {_number(ev, body, 'value')}"
    if body.tag == "TimeToCollisionCondition":
        if body.get("freespace", "true") != "true":
            raise ev.refuse("TimeToCollisionCondition with freespace false (footprints only)")
        other = body.find("./TimeToCollisionConditionTarget/EntityRef")
        if other is None:
            raise ev.refuse("TimeToCollisionCondition to a position")
        name = ev.add_measure("ttc", actor, other=other.get("entityRef"))
        return f"{name} {_rule(ev, body)} {_number(ev, body, 'value')}"
    raise ev.refuse(_chain(body))


def _action(ev: _Event, action: ET.Element) -> dict[str, Any]:
    body = _unwrap(action)
    if body.tag == "TrafficSignalStateAction":
        return {"type": "light", "id": body.get("name"), "state": body.get("state")}
    if body.tag == "EnvironmentAction":
        return {"type": "weather", **_weather(ev, body)}
    if body.tag == "CustomCommandAction":
        kind, text = body.get("type"), (body.text or "").strip()
        if kind == "carlaverse.message":
            return {"type": "message", "text": text}
        if kind == "carlaverse.release":
            return {"type": "release", "npc": text}
        raise ev.refuse(f"CustomCommandAction type {kind!r}")
    raise ev.refuse(_chain(body))


def _chain(element: ET.Element) -> str:
    """`<A><B><C>` down a line of single children: names what is really inside a wrapper."""
    tags = [element.tag]
    while len(element) == 1:
        element = element[0]
        tags.append(element.tag)
    return "".join(f"<{t}>" for t in tags)


def _weather(ev: _Event, action: ET.Element) -> dict[str, float]:
    env = action.find("Environment")
    if env is None:
        raise ev.refuse("an EnvironmentAction without an Environment (catalog references)")
    values: dict[str, float] = {}
    weather = env.find("Weather")
    for part in [] if weather is None else list(weather):
        if part.tag == "Sun":
            values["sun_azimuth_deg"] = math.degrees(float(part.get("azimuth", 0)))
            values["sun_altitude_deg"] = math.degrees(float(part.get("elevation", 0)))
        elif part.tag == "Fog":
            visual = float(part.get("visualRange", CLEAR_VISIBILITY_M))
            values["fog_density"] = min(1.0, max(0.0, 1 - visual / CLEAR_VISIBILITY_M))
        elif part.tag == "Precipitation":
            rate = part.get("precipitationIntensity") or part.get("intensity") or "0"
            values["precipitation"] = min(1.0, float(rate) / RAIN_FULL_MM_H)
        else:
            raise ev.refuse(f"<Weather><{part.tag}>")
    cover = (
        None if weather is None else weather.get("fractionalCloudCover", weather.get("cloudState"))
    )
    if cover is not None:
        if cover not in CLOUDS:
            raise ev.refuse(f"cloud cover {cover!r}")
        values["cloudiness"] = CLOUDS[cover]
    road = env.find("RoadCondition")
    wetness = None if road is None else road.get("wetness")
    if wetness:
        if wetness not in WETNESS:
            raise ev.refuse(f"road wetness {wetness!r}")
        values["wetness"] = WETNESS[wetness]
    return values


def _unwrap(element: ET.Element) -> ET.Element:
    """The first element below `element` that is not a plain container."""
    for child in element:
        if child.tag in ("TriggeringEntities", "StartTrigger"):
            continue
        return _unwrap(child) if child.tag in _WRAPPERS else child
    raise Refused(f"<{element.tag} name={element.get('name')!r}> is empty")


def _rule(ev: _Event, body: ET.Element) -> str:
    rule = body.get("rule", "")
    if rule not in RULES:
        raise ev.refuse(f"rule {rule!r} in <{body.tag}>")
    return RULES[rule]


def _world_position(ev: _Event, body: ET.Element) -> list[float]:
    position = body.find("./Position/WorldPosition")
    if position is None:
        raise ev.refuse(f"<{body.tag}> with a position other than WorldPosition")
    return [float(position.get("x", 0)), float(position.get("y", 0))]


def _identifier(name: str) -> str:
    cleaned = re.sub(r"\W", "_", name, flags=re.ASCII)  # Unicode letters are `\w` too
    return cleaned if re.match(r"[A-Za-z_]", cleaned) else f"e_{cleaned}"
