"""Scenario triggers: named measurements, a condition over them, and what happens when it holds.

The same critical encounter for every participant: a trigger measures the world each tick
(how soon a cyclist reaches a point, a speed, a TTC, being in a zone, having crossed a line),
evaluates its condition — a restricted expression over those names (`carlaverse.expr`), plus
`t` (scenario seconds) and `fired_<id>` (how often trigger <id> fired) — and, when it holds,
runs its actions:

    triggers:
      - id: pull_out
        measure:
          bike_eta: {type: eta, actor: bike-1, point: [164.0, 118.4]}
        when: "bike_eta < 6"
        actions:
          - {type: release, npc: waiting-car,
             arrive: {point: [164.0, 118.4], of: bike-1, ttc_s: 2.0}}
          - {type: message, to: bike-1, text: "Watch the junction", duration_s: 3}

A measurement of an actor that is not in the world is NaN, so every comparison with it is
false until the actor appears.
"""

from __future__ import annotations

from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.expr import ExpressionError, compile_condition
from carlaverse.patterns import anchored

Finite = Annotated[float, msgspec.Meta(ge=-1e9, le=1e9)]
Point = tuple[Finite, Finite]  # [m] world frame: x east, y north
Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Identifier = Annotated[str, msgspec.Meta(pattern=anchored("[A-Za-z_][A-Za-z0-9_]*"))]


# --------------------------------------------------------------------------- measurements


class Eta(StrictStruct, tag="eta"):
    """[s] until the actor's front reaches `point` at its current speed (inf if not closing)."""

    actor: str
    point: Point


class Distance(StrictStruct, tag="distance"):
    """[m] from the actor's centre to `point`, or to `other`'s centre."""

    actor: str
    point: Point | None = None
    other: str | None = None

    def __post_init__(self) -> None:
        if (self.point is None) == (self.other is None):
            raise ValueError("a distance measures to a point or to another actor: give one")


class Speed(StrictStruct, tag="speed"):
    """[m/s] the actor's speed."""

    actor: str


class Ttc(StrictStruct, tag="ttc"):
    """[s] time to collision of the two footprints at constant velocity (inf if none)."""

    actor: str
    other: str


class Inside(StrictStruct, tag="inside"):
    """1 while the actor's centre is inside the polygon, else 0."""

    actor: str
    polygon: Annotated[list[Point], msgspec.Meta(min_length=3)]


class Crossed(StrictStruct, tag="crossed"):
    """1 from the tick the actor's centre crossed the line segment on, else 0."""

    actor: str
    line: tuple[Point, Point]


Measure = Eta | Distance | Speed | Ttc | Inside | Crossed


# --------------------------------------------------------------------------- actions


class Arrival(StrictStruct):
    """Drive the NPC so its front reaches `point` when `of`'s ETA to it is `ttc_s`."""

    point: Point
    of: str
    ttc_s: NonNegative
    max_speed_mps: Positive = 15.0
    max_accel_mps2: Positive = 3.5
    max_decel_mps2: Positive = 6.0


class Spawn(StrictStruct, tag="spawn"):
    """A new NPC vehicle on a route, now."""

    id: str
    edges: Annotated[list[str], msgspec.Meta(min_length=1)]
    kind: str = "car"
    depart_pos_m: NonNegative = 0.0
    speed_mps: NonNegative = 0.0
    arrive: Arrival | None = None


class Release(StrictStruct, tag="release"):
    """Let a held NPC (a scripted vehicle waiting at its stop) drive on."""

    npc: str
    arrive: Arrival | None = None


class Light(StrictStruct, tag="light"):
    """Set a traffic light's state now (one SUMO state char per link); it then stays."""

    id: str
    state: Annotated[str, msgspec.Meta(pattern=anchored("[rygGoOsu]+"))]


class SetWeather(StrictStruct, tag="weather"):
    """Weather values that hold from now on, over the scenario's timeline."""

    sun_altitude_deg: Annotated[float, msgspec.Meta(ge=-90, le=90)] | None = None
    sun_azimuth_deg: float | None = None
    cloudiness: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    precipitation: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    fog_density: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    wetness: Annotated[float, msgspec.Meta(ge=0, le=1)] | None = None
    wind_speed_mps: NonNegative | None = None
    wind_direction_deg: float | None = None

    def values(self) -> dict[str, float]:
        return {k: v for k, v in msgspec.structs.asdict(self).items() if v is not None}


class Message(StrictStruct, tag="message"):
    """Text for a node's HMI (`to` a node id, or "" for everyone)."""

    text: Annotated[str, msgspec.Meta(min_length=1, max_length=500)]
    to: str = ""
    duration_s: Positive = 5.0


Action = Spawn | Release | Light | SetWeather | Message


class TriggerSpec(StrictStruct):
    id: Identifier
    when: str  # condition over the measurement names, t and fired_<id>
    actions: Annotated[list[Action], msgspec.Meta(min_length=1)]
    measure: dict[Identifier, Measure] = {}
    repeat: bool = False  # fire again each time the condition becomes true anew


def check_triggers(triggers: list[TriggerSpec]) -> None:
    """Unique ids, and every condition compiles over the names it may use (ValueError)."""
    ids = [t.id for t in triggers]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ValueError(f"trigger ids must be unique: {duplicates} appear more than once")
    fired = {f"fired_{i}" for i in ids}
    for trigger in triggers:
        names = {"t", *fired, *trigger.measure}
        try:
            compile_condition(trigger.when, names)
        except ExpressionError as exc:
            raise ValueError(f"trigger {trigger.id}: {exc}") from exc
