"""Weather in the picture: the sun as a directional light, sky colour, fog, clouds, wet roads.

- Sun: altitude above the horizon and azimuth as a compass bearing (0 north, 90 east,
  clockwise), both in degrees as in `Weather`. Its strength follows sin(altitude) and drops
  with cloudiness; ambient light keeps shadows readable and dims with the sun.
- Fog: exponential, visibility V = 3/k (the 5 % contrast distance, Koschmieder), with
  k = FOG_K_PER_M × fog_density; rain adds a little haze. Fog colour is the sky colour, so
  a distant object fades into the horizon.
- Wetness darkens the road surfaces (wet asphalt reflects less diffusely).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from panda3d.core import AmbientLight, DirectionalLight, Fog, NodePath, Vec3

from carlaverse.messages import Weather
from carlaverse.render import palette
from carlaverse.render.meshes import Color

FOG_K_PER_M = 0.06  # [1/m] extinction at fog_density 1: visibility 50 m
RAIN_K_PER_M = 0.01  # [1/m] extra extinction at full precipitation
WET_DARKENING = 0.45  # road brightness lost at wetness 1
CLOUD_DIMMING = 0.7  # sun strength lost at cloudiness 1
AMBIENT = (0.25, 0.45)  # ambient brightness at night .. at full day
DEFAULT = Weather(0, 0.0)


@dataclass(frozen=True, slots=True)
class Lighting:
    """The numbers a weather state turns into (testable without a renderer)."""

    sun_direction: tuple[float, float, float]  # unit vector the light travels along
    sun: float  # 0..1
    ambient: float  # 0..1
    sky: Color
    fog_k_per_m: float  # [1/m]
    road_brightness: float  # 0..1 colour scale of road surfaces


def lighting(w: Weather) -> Lighting:
    alt, az = math.radians(w.sun_altitude_deg), math.radians(w.sun_azimuth_deg)
    towards_sun = (math.sin(az) * math.cos(alt), math.cos(az) * math.cos(alt), math.sin(alt))
    day = max(0.0, math.sin(alt))
    sun = day * (1.0 - CLOUD_DIMMING * _unit(w.cloudiness))
    ambient = AMBIENT[0] + (AMBIENT[1] - AMBIENT[0]) * min(1.0, 3 * day)
    sky = _mix(palette.SKY_CLEAR, palette.SKY_OVERCAST, _unit(w.cloudiness))
    sky = _mix(palette.SKY_NIGHT, sky, min(1.0, 4 * day + 0.05))
    k = FOG_K_PER_M * _unit(w.fog_density) + RAIN_K_PER_M * _unit(w.precipitation)
    road = 1.0 - WET_DARKENING * _unit(w.wetness)
    return Lighting((-towards_sun[0], -towards_sun[1], -towards_sun[2]), sun, ambient, sky, k, road)


class WeatherLayer:
    """Owns the scene's lights and fog; `update` applies a Weather when it changes."""

    def __init__(self, world: NodePath, road: NodePath) -> None:
        self.world, self.road = world, road
        self._sun = DirectionalLight("sun")
        self._ambient = AmbientLight("ambient")
        self._sun_np = world.attach_new_node(self._sun)
        self._ambient_np = world.attach_new_node(self._ambient)
        world.set_light(self._sun_np)
        world.set_light(self._ambient_np)
        self._fog = Fog("weather")
        self._shown: Weather | None = None
        self.sky: Color = palette.SKY_CLEAR
        self.update(DEFAULT)

    def update(self, w: Weather | None) -> bool:
        """Apply `w` (None keeps the current); True if anything changed."""
        w = w or self._shown or DEFAULT
        if self._shown is not None and _same(w, self._shown):
            return False
        self._shown = w
        lit = lighting(w)
        self._sun.set_color((lit.sun, lit.sun * 0.97, lit.sun * 0.9, 1.0))
        self._sun_np.look_at(Vec3(*lit.sun_direction))
        self._ambient.set_color((lit.ambient, lit.ambient, lit.ambient * 1.05, 1.0))
        self.sky = lit.sky
        self._fog_to(lit)
        self.road.set_color_scale(lit.road_brightness, lit.road_brightness, lit.road_brightness, 1)
        return True

    def _fog_to(self, lit: Lighting) -> None:
        if lit.fog_k_per_m <= 0:
            self.world.clear_fog()
            return
        self._fog.set_color(*lit.sky[:3])
        self._fog.set_exp_density(lit.fog_k_per_m)
        self.world.set_fog(self._fog)


def _same(a: Weather, b: Weather) -> bool:
    fields = ("sun_altitude_deg", "sun_azimuth_deg", "cloudiness", "precipitation")
    fields += ("fog_density", "wetness")
    return all(getattr(a, f) == getattr(b, f) for f in fields)


def _unit(v: float) -> float:
    return min(1.0, max(0.0, v))


def _mix(a: Color, b: Color, u: float) -> Color:
    return (
        a[0] + (b[0] - a[0]) * u,
        a[1] + (b[1] - a[1]) * u,
        a[2] + (b[2] - a[2]) * u,
        1.0,
    )
