"""Weather in the picture: the sun as a directional light, sky colour, fog, clouds, wet roads.

- Sun: altitude above the horizon and azimuth as a compass bearing (0 north, 90 east,
  clockwise), both in degrees as in `Weather`. Its strength follows sin(altitude) and drops
  with cloudiness; ambient light keeps shadows readable and dims with the sun.
- Fog: exponential, visibility V = 3/k (the 5 % contrast distance, Koschmieder), with
  k = FOG_K_PER_M × fog_density; rain adds a little haze. Fog colour is the sky colour, so
  a distant object fades into the horizon.
- Wetness darkens the road surfaces (wet asphalt reflects less diffusely).

Two ways to apply it, by quality (`quality.py`): `flat` drives Panda3D's fixed-function
lights, fog and a colour scale on the road, as the renderer always did; the shaded presets
hand the daylight of `sky.py` (sun, sky, exposure, night) and the weather's wetness, fog and
clouds to the shaders as inputs on the world node.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from panda3d.core import AmbientLight, DirectionalLight, Fog, NodePath, Vec3, Vec4

from carlaverse.messages import Weather
from carlaverse.render import palette
from carlaverse.render.meshes import Color
from carlaverse.render.sky import Daylight, daylight, on_screen

FOG_K_PER_M = 0.06  # [1/m] extinction at fog_density 1: visibility 50 m
RAIN_K_PER_M = 0.01  # [1/m] extra extinction at full precipitation
WET_DARKENING = 0.45  # road brightness lost at wetness 1
CLOUD_DIMMING = 0.7  # sun strength lost at cloudiness 1
AMBIENT = (0.25, 0.45)  # ambient brightness at night .. at full day
HAZE_K_PER_M = 0.0008  # [1/m] clear air's own extinction in the shaded look (visibility ~4 km)
CLOUD_DRIFT = 0.004  # pattern units per metre of wind per second (texture tiles ~250 m of sky)
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

    def __init__(self, world: NodePath, road: NodePath, shaded: bool = False) -> None:
        self.world, self.road, self.shaded = world, road, shaded
        self._sun = DirectionalLight("sun")
        self._ambient = AmbientLight("ambient")
        self._sun_np = world.attach_new_node(self._sun)
        self._ambient_np = world.attach_new_node(self._ambient)
        world.set_light(self._sun_np)
        world.set_light(self._ambient_np)
        self._fog = Fog("weather")
        self._shown: Weather | None = None
        self.sky: Color = palette.SKY_CLEAR
        self.daylight: Daylight = daylight(DEFAULT)
        self.update(DEFAULT)

    @property
    def shown(self) -> Weather:
        """The weather applied last."""
        return self._shown or DEFAULT

    def update(self, w: Weather | None, t: float = 0.0) -> bool:
        """Apply `w` (None keeps the current) at render time `t` [s]; True if it changed."""
        w = w or self._shown or DEFAULT
        if self.shaded:
            self._drift_clouds(w, t)
        if self._shown is not None and _same(w, self._shown):
            return False
        self._shown = w
        lit = lighting(w)
        self.sky = lit.sky
        if self.shaded:
            self._to_shaders(w, lit)
            # past the ground's edge, below the sky dome, the view meets the fogged horizon
            self.sky = on_screen(_fog_colour(self.daylight, w), self.daylight.exposure)
            return True
        self._sun.set_color((lit.sun, lit.sun * 0.97, lit.sun * 0.9, 1.0))
        self._sun_np.look_at(Vec3(*lit.sun_direction))
        self._ambient.set_color((lit.ambient, lit.ambient, lit.ambient * 1.05, 1.0))
        self._fog_to(lit)
        self.road.set_color_scale(lit.road_brightness, lit.road_brightness, lit.road_brightness, 1)
        return True

    def _to_shaders(self, w: Weather, lit: Lighting) -> None:
        day = self.daylight = daylight(w)
        # alpha 0 marks the scene's ambient: a node with no light at all gets alpha 1 (emissive)
        self._ambient.set_color((0.0, 0.0, 0.0, 0.0))
        inputs = {
            "sun_dir": Vec3(*day.towards_sun), "sun_color": Vec3(*day.sun),
            "sun_glow": Vec3(*day.sun_glow), "sky_zenith": Vec3(*day.zenith),
            "sky_horizon": Vec3(*day.horizon), "sky_ambient": Vec3(*day.sky_ambient),
            "ground_ambient": Vec3(*day.ground_ambient), "exposure": day.exposure,
            "night": day.night, "wetness": _unit(w.wetness),
            "fog": Vec4(*_fog_colour(day, w), lit.fog_k_per_m + HAZE_K_PER_M),
        }  # fmt: skip
        for name, value in inputs.items():
            self.world.set_shader_input(name, value)

    def _drift_clouds(self, w: Weather, t: float) -> None:
        """Clouds move with the wind, from where it blows (a compass bearing) [pattern units]."""
        toward = math.radians(w.wind_direction_deg + 180.0)
        run = CLOUD_DRIFT * max(0.0, w.wind_speed_mps) * t
        drift = (math.sin(toward) * run % 1.0, math.cos(toward) * run % 1.0)
        self.world.set_shader_input("clouds", Vec4(_unit(w.cloudiness), 0.0, *drift))

    def _fog_to(self, lit: Lighting) -> None:
        if lit.fog_k_per_m <= 0:
            self.world.clear_fog()
            return
        self._fog.set_color(*lit.sky[:3])
        self._fog.set_exp_density(lit.fog_k_per_m)
        self.world.set_fog(self._fog)


def _fog_colour(day: Daylight, w: Weather) -> tuple[float, float, float]:
    """Fog is lit air: the horizon's colour, greyer as it thickens (droplets scatter white)."""
    grey = sum(day.horizon) / 3
    u = _unit(w.fog_density)
    return (
        day.horizon[0] + (grey - day.horizon[0]) * u,
        day.horizon[1] + (grey - day.horizon[1]) * u,
        day.horizon[2] + (grey - day.horizon[2]) * u,
    )


def _same(a: Weather, b: Weather) -> bool:
    fields: tuple[str, ...] = ("sun_altitude_deg", "sun_azimuth_deg", "cloudiness", "precipitation")
    fields += ("fog_density", "wetness", "wind_speed_mps", "wind_direction_deg")
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
