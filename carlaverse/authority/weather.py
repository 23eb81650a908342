"""Weather: the scenario's state, an optional timeline, and when to publish it.

The timeline's keyframes name only the fields they change; between keyframes every field is
interpolated linearly (angles along the shorter arc). The state is published when it has
changed noticeably since the last message, and at `status_rate_hz` regardless, so a node that
missed one message is corrected within a second.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

from carlaverse.messages import Weather
from carlaverse.support.angles import wrap_degrees
from carlaverse.traffic.scenario import WeatherKey, WeatherSpec, WeatherValues

ANGLE_FIELDS = {"sun_azimuth_deg", "wind_direction_deg"}
# Smallest change worth a message: 0.2° of sun, 1 % of a 0..1 quantity, 0.1 m/s of wind.
CHANGE_EPS = {"sun_altitude_deg": 0.2, "sun_azimuth_deg": 0.2, "wind_direction_deg": 1.0,
              "wind_speed_mps": 0.1}  # fmt: skip
DEFAULT_EPS = 0.01
VALUE_FIELDS: tuple[str, ...] = WeatherValues.__struct_fields__


@dataclass(frozen=True, slots=True)
class _Frame:
    at_s: float  # [s]
    values: dict[str, float]


class WeatherTimeline:
    """Weather values as a function of scenario time."""

    def __init__(self, spec: WeatherSpec) -> None:
        self._loop_s = spec.loop_s
        current = {f: float(getattr(spec.initial, f)) for f in VALUE_FIELDS}
        self._frames = [_Frame(0.0, dict(current))]
        for key in spec.timeline:
            current = {**current, **_named(key)}
            if key.at_s <= 0.0:  # a keyframe at 0 refines the initial state
                self._frames[0] = _Frame(0.0, dict(current))
            else:
                self._frames.append(_Frame(key.at_s, dict(current)))

    def values_at(self, scenario_s: float) -> dict[str, float]:
        s = scenario_s % self._loop_s if self._loop_s else scenario_s
        frames = self._frames
        if s <= frames[0].at_s:
            return dict(frames[0].values)
        for before, after in itertools.pairwise(frames):
            if s < after.at_s:
                span = after.at_s - before.at_s
                return _blend(before.values, after.values, (s - before.at_s) / span if span else 1)
        return dict(frames[-1].values)


class WeatherPublisher:
    """Decides when the weather goes out and builds the message."""

    def __init__(self, spec: WeatherSpec, status_rate_hz: float) -> None:
        self._timeline = WeatherTimeline(spec)
        self._period_s = 1.0 / status_rate_hz
        self._sent: dict[str, float] | None = None
        self._sent_t = -math.inf
        self._override: dict[str, float] = {}  # set by scenario triggers, over the timeline
        self.latest: Weather | None = None

    def override(self, values: dict[str, float]) -> None:
        """These values hold from now on, whatever the timeline says (a trigger's action)."""
        self._override.update(values)

    def tick(self, t: float, scenario_s: float, next_seq: Callable[[], int]) -> Weather | None:
        """The message to publish at session time `t`, or None when nothing is due."""
        values = {**self._timeline.values_at(scenario_s), **self._override}
        due = t - self._sent_t >= self._period_s - 1e-9
        if not due and self._sent is not None and not _changed(self._sent, values):
            return None
        self._sent, self._sent_t = values, t
        self.latest = Weather(next_seq(), t, **values)
        return self.latest


def _named(key: WeatherKey) -> dict[str, float]:
    return {f: float(v) for f in VALUE_FIELDS if (v := getattr(key, f)) is not None}


def _blend(a: dict[str, float], b: dict[str, float], w: float) -> dict[str, float]:
    out = {}
    for name in a:
        if name in ANGLE_FIELDS:
            delta = wrap_degrees(b[name] - a[name])
            out[name] = (a[name] + w * delta) % 360.0
        else:
            out[name] = a[name] + w * (b[name] - a[name])
    return out


def _changed(old: dict[str, float], new: dict[str, float]) -> bool:
    for name, value in new.items():
        delta = value - old[name]
        if name in ANGLE_FIELDS:
            delta = wrap_degrees(delta)
        if abs(delta) >= CHANGE_EPS.get(name, DEFAULT_EPS):
            return True
    return False
