"""The session's weather (`world/weather`) as OSI's EnvironmentalConditions.

Angles: our sun azimuth and wind direction are compass bearings (0 north, 90 east, clockwise;
the wind's is where it blows from); OSI counts both counter-clockwise from north (0 north,
pi/2 west, 3/2 pi east; osi_environment.proto, Sun.azimuth and Wind.origin_direction), so
each is the bearing's negative, modulo 2 pi. Elevation is the same angle in radians.

Categories: OSI discretises precipitation by intensity in mm/h and fog by visibility in m
(osi_environment.proto, after Paulat et al. 2008 for rain). Our weather's precipitation and
fog density are 0..1; README ("Scenario triggers") fixes the scale both ways: rain of
10 mm/h is 1.0, and fog density is 1 - visibility / 1000 m. A density of 0 draws no fog.
"""

from __future__ import annotations

import bisect
import math

from osi3.osi_environment_pb2 import EnvironmentalConditions

from carlaverse import messages as m

RAIN_FULL_MM_H = 10.0  # [mm/h] precipitation 1.0 (README "Scenario triggers")
CLEAR_VISIBILITY_M = 1000.0  # [m] fog density 0 at this visibility (README, idem)
E = EnvironmentalConditions
# (lower bound, category), ascending: I in [0.1, 0.5[ mm/h is very light, ...
PRECIPITATION = [
    (0.0, E.PRECIPITATION_NONE), (0.1, E.PRECIPITATION_VERY_LIGHT),
    (0.5, E.PRECIPITATION_LIGHT), (1.9, E.PRECIPITATION_MODERATE),
    (8.1, E.PRECIPITATION_HEAVY), (34.0, E.PRECIPITATION_VERY_HEAVY),
    (149.0, E.PRECIPITATION_EXTREME),
]  # fmt: skip
# (lower bound of visibility [m], category), ascending
FOG = [
    (0.0, E.FOG_DENSE), (50.0, E.FOG_THICK), (200.0, E.FOG_LIGHT), (1000.0, E.FOG_MIST),
    (2000.0, E.FOG_POOR_VISIBILITY), (4000.0, E.FOG_MODERATE_VISIBILITY),
    (10000.0, E.FOG_GOOD_VISIBILITY), (40000.0, E.FOG_EXCELLENT_VISIBILITY),
]  # fmt: skip
OKTAS = [
    E.CloudLayer.FRACTIONAL_CLOUD_COVER_ZERO_OKTAS, E.CloudLayer.FRACTIONAL_CLOUD_COVER_ONE_OKTAS,
    E.CloudLayer.FRACTIONAL_CLOUD_COVER_TWO_OKTAS, E.CloudLayer.FRACTIONAL_CLOUD_COVER_THREE_OKTAS,
    E.CloudLayer.FRACTIONAL_CLOUD_COVER_FOUR_OKTAS, E.CloudLayer.FRACTIONAL_CLOUD_COVER_FIVE_OKTAS,
    E.CloudLayer.FRACTIONAL_CLOUD_COVER_SIX_OKTAS, E.CloudLayer.FRACTIONAL_CLOUD_COVER_SEVEN_OKTAS,
    E.CloudLayer.FRACTIONAL_CLOUD_COVER_EIGHT_OKTAS,
]  # fmt: skip


def _category(table: list[tuple[float, int]], value: float) -> int:
    return table[max(0, bisect.bisect_right([low for low, _ in table], value) - 1)][1]


def osi_angle(bearing_deg: float) -> float:
    """[rad] a compass bearing (clockwise from north) as OSI's counter-clockwise angle."""
    return (-math.radians(bearing_deg)) % (2 * math.pi)


def conditions(weather: m.Weather) -> EnvironmentalConditions:
    out = EnvironmentalConditions()
    out.sun.azimuth = osi_angle(weather.sun_azimuth_deg)
    out.sun.elevation = math.radians(weather.sun_altitude_deg)
    out.wind.origin_direction = osi_angle(weather.wind_direction_deg)
    out.wind.speed = weather.wind_speed_mps
    out.precipitation = _category(PRECIPITATION, weather.precipitation * RAIN_FULL_MM_H)
    fog = min(1.0, max(0.0, weather.fog_density))
    visibility = math.inf if fog == 0 else (1 - fog) * CLEAR_VISIBILITY_M
    out.fog = _category(FOG, visibility)
    cover = min(1.0, max(0.0, weather.cloudiness))
    out.clouds.fractional_cloud_cover = OKTAS[round(cover * 8)]
    return out
