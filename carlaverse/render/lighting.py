"""The scene's light, put together per quality preset: shading, sky, sun, night, rain.

`SceneLighting` owns every room that lights the world and calls them once per frame:

- `weather` (sun, sky and fog numbers, fixed-function for `flat`, shader inputs otherwise),
- `sky_dome` (the sky drawn around the eye), `shadows` (the sun's shadow map),
- `headlights` (spotlights and glare from the vehicles' lamp bits), `street_lights`
  (poles and their baked light), `rain` (streaks around the eye).

The surface shader (`shaders.SURFACE_*`) goes on the world node, so everything under it —
map, actors, signal heads — is lit the same way; a node tunes its material with the
`surface` input (wet response, roughness, unused, gloss).
"""

from __future__ import annotations

from dataclasses import dataclass

from panda3d.core import NodePath, Shader, Vec4

from carlaverse.messages import MapReply
from carlaverse.render.frame import SceneFrame
from carlaverse.render.graphics import Graphics
from carlaverse.render.headlights import Headlights
from carlaverse.render.rain import Rain
from carlaverse.render.shaders import surface_sources
from carlaverse.render.shadows import SHADOW_MASK, SUN_UP_Z, SunShadow
from carlaverse.render.sky_dome import SkyDome
from carlaverse.render.street_lights import StreetLights
from carlaverse.render.weather import WeatherLayer


@dataclass(frozen=True, slots=True)
class Material:
    """How a surface answers light: the `surface` shader input."""

    wet_response: float  # 0..1: how much of the weather's wetness it holds
    roughness: float  # 0 mirror .. 1 matte
    gloss: float  # 0..1: sky reflected even when dry (paint, glass)

    def input(self) -> Vec4:
        return Vec4(self.wet_response, self.roughness, 0.0, self.gloss)


DEFAULT_MATERIAL = Material(0.6, 0.85, 0.0)  # ground, walls, roofs: matte, partly puddled
ROAD_MATERIAL = Material(1.0, 0.7, 0.0)  # asphalt: wets all over
VEHICLE_MATERIAL = Material(0.2, 0.35, 0.12)  # paint and glass


class SceneLighting:
    """Every lighting room of one preset, under `world`."""

    def __init__(self, world: NodePath, graphics: Graphics, road: NodePath,
                 road_map: MapReply | None, bounds: tuple[float, float, float, float],
                 far_m: float) -> None:  # fmt: skip
        self.world, self.preset = world, graphics.preset
        preset = self.preset
        self.weather = WeatherLayer(world, road, shaded=preset.shaded)
        self.dome: SkyDome | None = None
        self.shadow: SunShadow | None = None
        self.headlights: Headlights | None = None
        self.street: StreetLights | None = None
        self.rain: Rain | None = None
        if not preset.shaded:
            return
        self._shaders: dict[tuple[bool, bool], Shader] = {}  # by (night, sun up), made on need
        _start_inputs(world)
        road.set_shader_input("surface", ROAD_MATERIAL.input())
        antialias = graphics.antialias()
        if antialias is not None:
            world.set_attrib(antialias)
        self.dome = SkyDome(world, preset, 0.5 * far_m, SHADOW_MASK)
        if preset.shadow_map_px:
            self.shadow = SunShadow(world, graphics, preset)
        self.headlights = Headlights(world, preset)
        if preset.street_lights:
            self.street = StreetLights(world, road_map.lanes if road_map else [], bounds)
        if preset.rain_streaks:
            self.rain = Rain(world, preset)
        self._aim_sun()

    def vehicles(self, root: NodePath) -> None:
        """Give the actor layer's root the vehicles' material."""
        if self.preset.shaded:
            root.set_shader_input("surface", VEHICLE_MATERIAL.input())

    def update(self, frame: SceneFrame, head: NodePath, own: str | None) -> bool:
        """Light `frame` seen from `head`; True if the weather changed (the clear colour too)."""
        changed = self.weather.update(frame.weather, frame.t)
        if changed:
            self._aim_sun()
        if self.dome is not None:
            self.dome.follow(head)
        if self.shadow is not None:
            self.shadow.follow(head)
        if self.headlights is not None:
            self.headlights.update(frame.actors, head, own)
        if self.rain is not None:
            self.rain.update(self.weather.shown, frame.t)
        return changed

    def _aim_sun(self) -> None:
        if not self.preset.shaded:
            return
        day = self.weather.daylight
        key = (day.night > 0.0, day.towards_sun[2] > SUN_UP_Z)
        if key not in self._shaders:
            self._shaders[key] = Shader.make(Shader.SL_GLSL, *surface_sources(self.preset, *key))
        self.world.set_shader(self._shaders[key])
        if self.shadow is not None:
            self.shadow.aim(day.towards_sun)
        if self.street is not None:
            self.street.night(day.night)

    def close(self) -> None:
        if self.shadow is not None:
            self.shadow.close()


def _start_inputs(world: NodePath) -> None:
    """A start value for the inputs the surface shader reads that no room sets."""
    world.set_shader_input("surface", DEFAULT_MATERIAL.input())
    world.set_shader_input("wetness", 0.0)
    world.set_shader_input("clouds", Vec4(0, 0, 0, 0))
