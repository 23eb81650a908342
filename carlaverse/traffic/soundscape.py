"""A scenario's `audio:` section: who may hear what, sirens and construction zones.

    audio:
      rate_hz: 20            # audio/<id> scenes per second
      max_emitters: 32       # per listener, loudest first
      threshold_db: 30       # [dB SPL] estimated level at the listener to be sent at all
      sirens: [{vehicle: ambulance, pattern: wail}]
      construction: [{name: dig, x: 120, y: 60, radius_m: 12}]

Sirens ride on the NPCs whose ids the scenario knows: scripted vehicles
(`traffic.scripted_vehicles`) and those its triggers spawn. The authority puts everything else
(engines, tyres, leaves, water, rain, wind) together from its own state (docs/architecture.md
§6).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Literal, Protocol

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.messages import AUDIO_MAX_EMITTERS, SIREN_PATTERNS
from carlaverse.patterns import anchored
from carlaverse.traffic.trigger_spec import Spawn, TriggerSpec


class HasId(Protocol):
    @property
    def id(self) -> str: ...  # read-only, so a frozen Struct's field satisfies it


SirenPattern = Literal[SIREN_PATTERNS]  # type: ignore[valid-type]  # the wire's pattern table
SoundLevel = Annotated[float, msgspec.Meta(ge=0, le=194)]  # [dB SPL]; 194 dB = 1 atm peak
Intensity = Annotated[float, msgspec.Meta(ge=0, le=1)]


class SirenSpec(StrictStruct):
    """An emergency vehicle's siren, sounding while the vehicle is in the traffic."""

    vehicle: str  # id of a scripted vehicle
    pattern: SirenPattern = "wail"
    level_db: SoundLevel = 118.0  # [dB SPL] at 1 m; EN 1789 sirens are 110-125 dB


class ConstructionZone(StrictStruct):
    """A work site heard as one area source (machines, hammering) of the given radius."""

    name: Annotated[str, msgspec.Meta(pattern=anchored(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,62}"))]
    x: float  # [m] map frame, centre
    y: float  # [m]
    z: float = 0.0  # [m]
    radius_m: Annotated[float, msgspec.Meta(ge=0, le=10_000)] = 10.0  # [m]
    level_db: SoundLevel = 95.0  # [dB SPL] 1 m outside the zone (a breaker: ~100 dB)
    intensity: Intensity = 1.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.z)):
            raise ValueError(f"construction zone {self.name!r}: x, y, z must be finite numbers")


class AudioSpec(StrictStruct):
    enabled: bool = True
    rate_hz: Annotated[float, msgspec.Meta(gt=0, le=100)] = 20.0  # [Hz] scenes per listener
    max_emitters: Annotated[int, msgspec.Meta(ge=1, le=AUDIO_MAX_EMITTERS)] = 32
    # [dB SPL] a source whose level at the listener (at 1 m − 20·log10 distance) is below this
    # is not sent; quiet-street background is ~40 dB, so 30 dB keeps what could still be heard.
    threshold_db: Annotated[float, msgspec.Meta(ge=-50, le=194)] = 30.0
    map_ambience: bool = True  # leaves in vegetation areas, water from water areas
    sirens: list[SirenSpec] = []
    construction: list[ConstructionZone] = []

    def __post_init__(self) -> None:
        _unique("siren vehicle", [s.vehicle for s in self.sirens])
        _unique("construction zone name", [z.name for z in self.construction])


def named_vehicles(scripted: Sequence[HasId], triggers: Sequence[TriggerSpec]) -> list[str]:
    """Ids of the NPC vehicles a scenario names: its scripted ones and its triggers' spawns."""
    spawned = [a.id for t in triggers for a in t.actions if isinstance(a, Spawn)]
    return [*(v.id for v in scripted), *spawned]


def check_siren_vehicles(audio: AudioSpec, vehicle_ids: list[str]) -> None:
    """Every siren must ride on a vehicle the scenario names (scripted, or a trigger's spawn)."""
    for siren in audio.sirens:
        if siren.vehicle not in vehicle_ids:
            raise ValueError(
                f"audio.sirens: vehicle {siren.vehicle!r} is not a vehicle of this scenario; "
                "declare it under traffic.scripted_vehicles or spawn it from a trigger "
                f"(known: {vehicle_ids or 'none'})"
            )


def _unique(what: str, values: list[str]) -> None:
    seen = {v for v in values if values.count(v) > 1}
    if seen:
        raise ValueError(f"duplicate {what} {sorted(seen)}: each must be unique")
