"""Daylight from a weather state: the sun's direction and colour, the sky's, and the exposure.

Radiometry in relative linear units: 1.0 is the irradiance of a clear zenith sun on a surface
facing it. A surface's colour is albedo × irradiance (sun + sky + lamps) × exposure, then tone
mapped (`shaders/`). No Panda3D here, so the numbers are testable on their own.

- **Sun**: direction from altitude and azimuth (compass bearing: 0 north = +y, 90 east = +x,
  clockwise). Its colour is the solar spectrum through the atmosphere's air mass
  m (Kasten & Young 1989, m = 1/(sin h + 0.50572·(h + 6.07995°)^−1.6364)) with per-channel
  optical depths τ (Rayleigh λ⁻⁴ plus aerosol): T = exp(−τ·m), so a low sun is orange-red and
  dim. Clouds dim it by CLOUD_DIMMING × cloudiness.
- **Sky**: a zenith and a horizon radiance whose level follows the sun's altitude — sin(h)^0.8
  by day (a clear sky at 5° is about a quarter as bright as at 40°) and a twilight that fades
  by e every TWILIGHT_DEG below the horizon (civil twilight ends at −6°, astronomical at
  −18°) — down to a town's night skyglow. A glow around the sun
  takes the sun's transmitted colour, so dawn and dusk redden the sky near it. Cloudiness turns
  both towards a grey overcast, darker the thicker the cloud. A low sun warms the horizon
  all round (the light reaching it has crossed the most air).
- **Exposure**: like an eye or a camera adapting, but partly: exposure = EXPOSURE_K ·
  (E + ADAPT_FLOOR_E)^−ADAPTATION for the adapting irradiance E (sun on the ground and sky).
  With an exponent under 1 a scene 100× darker is shown 100^0.5 = 10× darker, so dusk is dusk
  and night stays darker than day.
- **Night**: 0 by day, 1 once the sun is ADAPT below the horizon; it switches on street lights,
  lit windows and (by its own bits) nothing else.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from carlaverse.messages import Weather

RGB = tuple[float, float, float]

TAU: RGB = (0.14, 0.20, 0.34)  # optical depth at zenith, red/green/blue (Rayleigh + aerosol)
CLOUD_DIMMING = 0.8  # direct sun lost at cloudiness 1
TWILIGHT_DEG = 3.5  # [deg] the sky's light falls by e per this much sun below the horizon
GLOW_LOWEST_DEG = 1.5  # [deg] the glow's hue after sunset: that of a sun this high
WARM_HORIZON, WARM_BELOW_DEG = 0.85, 15.0  # a low sun's tint on the horizon, and from when
ZENITH_DAY: RGB = (0.03, 0.10, 0.42)
HORIZON_DAY: RGB = (0.34, 0.42, 0.56)
OVERCAST: RGB = (0.50, 0.52, 0.55)
ZENITH_NIGHT: RGB = (0.0006, 0.0008, 0.0018)  # a town's skyglow, no moon
HORIZON_NIGHT: RGB = (0.0022, 0.0020, 0.0024)
AMBIENT_GAIN = 0.9  # sky irradiance on an up-facing surface per unit of mean sky radiance
AMBIENT_GREY = 0.4  # how far the sky's light is greyed from the mean sky colour
GROUND_BOUNCE = 0.12  # light the ground returns upwards, per unit of what falls on it
EXPOSURE_K = 1.65
ADAPTATION = 0.5  # exponent of the partial adaptation
ADAPT_FLOOR_E = 0.005  # adapting irradiance the eye never goes below
NIGHT_ON_DEG, NIGHT_FULL_DEG = 4.0, -2.0  # [deg] lamps come on between these sun altitudes


@dataclass(frozen=True, slots=True)
class Daylight:
    """What the shaders need from a weather state (all colours linear RGB)."""

    towards_sun: tuple[float, float, float]  # unit vector, world frame (x east, y north, z up)
    sun: RGB  # irradiance on a surface facing the sun (0 below the horizon)
    sun_glow: RGB  # sky radiance added around the sun
    zenith: RGB
    horizon: RGB
    sky_ambient: RGB  # irradiance from the sky on an up-facing surface
    ground_ambient: RGB  # irradiance from the ground on a down-facing surface
    exposure: float
    night: float  # 0 day .. 1 lamps fully on


def towards_sun(altitude_deg: float, azimuth_deg: float) -> tuple[float, float, float]:
    """Unit vector from the eye to the sun, world frame."""
    alt, az = math.radians(altitude_deg), math.radians(azimuth_deg)
    return (math.sin(az) * math.cos(alt), math.cos(az) * math.cos(alt), math.sin(alt))


def air_mass(altitude_deg: float) -> float:
    """Relative optical path through the atmosphere (Kasten & Young 1989); 1 at the zenith."""
    h = max(altitude_deg, -6.0)
    return 1.0 / (math.sin(math.radians(h)) + 0.50572 * (h + 6.07995) ** -1.6364)


def transmittance(altitude_deg: float) -> RGB:
    """The sun's colour after its path through the air, relative to the zenith sun."""
    m = air_mass(altitude_deg)
    return _rgb(math.exp(-t * (m - 1.0)) for t in TAU)


def sky_level(altitude_deg: float) -> float:
    """The sky's brightness, 1 with the sun at the zenith, ~0 at astronomical night."""
    day = max(0.0, math.sin(math.radians(altitude_deg))) ** 0.8
    twilight = math.exp(min(altitude_deg, 0.0) / TWILIGHT_DEG)
    return 0.94 * day + 0.06 * twilight


def daylight(w: Weather) -> Daylight:
    h, cloud = w.sun_altitude_deg, _unit(w.cloudiness)
    sun_t = transmittance(h)
    sun = _scale(sun_t, (1.0 - CLOUD_DIMMING * cloud) * _above_horizon(h))
    level = sky_level(h)
    grey = _scale(OVERCAST, level * (1.0 - 0.6 * cloud))
    zenith = _add(_mix(_scale(ZENITH_DAY, level), grey, cloud), ZENITH_NIGHT)
    clear_horizon = _mix(HORIZON_DAY, _scale(glow_colour(h), _lum(HORIZON_DAY)), warmth(h))
    horizon = _add(_mix(_scale(clear_horizon, level), grey, cloud), HORIZON_NIGHT)
    glow = _scale(glow_colour(h), 0.6 * level * (1.0 - cloud))
    # the sky's light on a surface: its mean radiance, less blue than the zenith (the bright
    # aureole round the sun and the haze near the horizon are white)
    sky_ambient = _desaturate(_scale(_add(zenith, horizon), AMBIENT_GAIN / 2), AMBIENT_GREY)
    sun_on_ground = max(0.0, math.sin(math.radians(h))) * _lum(sun)
    ground = _scale(_add(sky_ambient, (sun_on_ground,) * 3), GROUND_BOUNCE)
    adapting = sun_on_ground + _lum(sky_ambient)
    return Daylight(
        towards_sun=towards_sun(h, w.sun_azimuth_deg), sun=sun, sun_glow=glow, zenith=zenith,
        horizon=horizon, sky_ambient=sky_ambient, ground_ambient=ground,
        exposure=EXPOSURE_K * (adapting + ADAPT_FLOOR_E) ** -ADAPTATION, night=night_level(h),
    )  # fmt: skip


def glow_colour(altitude_deg: float) -> RGB:
    """The hue of the sky around the sun: its transmitted colour, brightest channel 1 (after
    sunset the glow keeps the colour of a sun just on the horizon)."""
    t = transmittance(max(altitude_deg, GLOW_LOWEST_DEG))
    return _scale(t, 1.0 / max(t))


def warmth(altitude_deg: float) -> float:
    """How much a low sun tints the whole horizon: WARM_HORIZON at sunset, 0 from 15° up."""
    u = min(1.0, max(0.0, altitude_deg / WARM_BELOW_DEG))
    return WARM_HORIZON * (1.0 - u * u * (3 - 2 * u))


def on_screen(c: RGB, exposure: float) -> tuple[float, float, float, float]:
    """A linear colour as the shaders put it on screen: exposed, ACES tone-mapped (Narkowicz's
    fit), encoded with γ 2.2 — for colours set outside them (a clear colour)."""
    out = []
    for x in c:
        x *= exposure
        x = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
        out.append(min(1.0, max(0.0, x)) ** (1 / 2.2))
    return (out[0], out[1], out[2], 1.0)


def night_level(altitude_deg: float) -> float:
    """0 by day, 1 once street lights are fully on (a smoothstep over NIGHT_ON..FULL)."""
    u = (NIGHT_ON_DEG - altitude_deg) / (NIGHT_ON_DEG - NIGHT_FULL_DEG)
    u = min(1.0, max(0.0, u))
    return u * u * (3 - 2 * u)


def _above_horizon(altitude_deg: float) -> float:
    """The sun's disc sets over its 0.53° diameter: direct light fades out across it."""
    return min(1.0, max(0.0, (altitude_deg + 0.27) / 0.53))


def _desaturate(c: RGB, u: float) -> RGB:
    grey = _lum(c)
    return _mix(c, (grey, grey, grey), u)


def _lum(c: RGB) -> float:
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def _rgb(values: Iterable[float]) -> RGB:
    r, g, b = values
    return (float(r), float(g), float(b))


def _scale(c: RGB, k: float) -> RGB:
    return (c[0] * k, c[1] * k, c[2] * k)


def _add(a: RGB, b: RGB) -> RGB:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _mix(a: RGB, b: RGB, u: float) -> RGB:
    return (a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u, a[2] + (b[2] - a[2]) * u)


def _unit(v: float) -> float:
    return min(1.0, max(0.0, v))
