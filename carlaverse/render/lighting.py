"""The scene's light, put together per quality preset: shading, sky, sun, night, rain.

`SceneLighting` owns every room that lights the world and calls them once per frame:

- `weather` (sun, sky and fog numbers, fixed-function for `flat`, shader inputs otherwise),
- `sky_dome` (the sky drawn around the eye), `shadows` (the sun's shadow map) and
  `shadow_proxies` (actors' boxes in it, where the preset says so),
- `headlights` (spotlights and glare from the vehicles' lamp bits), `street_lights`
  (poles and their baked light), `rain` (streaks around the eye).

The surface shader (`shaders.SURFACE_*`) goes on the world node, so everything under it —
map, actors, signal heads — is lit the same way; a node tunes its material with the
`surface` input (wet response, roughness, flags, gloss).
"""

from __future__ import annotations

from dataclasses import dataclass

from panda3d.core import CullBinManager, NodePath, Shader, TextureAttrib, TextureStage, Vec4

from carlaverse.messages import MapReply
from carlaverse.render.frame import SceneFrame
from carlaverse.render.graphics import Graphics
from carlaverse.render.headlights import Headlights
from carlaverse.render.rain import Rain
from carlaverse.render.shaders import surface_sources
from carlaverse.render.shadow_proxies import ShadowBoxes
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
    pools: bool = False  # lit per vertex, it still takes the nearest headlights per pixel
    windows: bool = False  # it carries an emission stage (a facade's lit windows)

    def input(self) -> Vec4:
        flags = (1 if self.pools else 0) | (2 if self.windows else 0)  # shaders.POOLS, WINDOWS
        return Vec4(self.wet_response, self.roughness, float(flags), self.gloss)


DEFAULT_MATERIAL = Material(0.6, 0.85, 0.0)  # ground, walls, roofs: matte, partly puddled
ROAD_MATERIAL = Material(1.0, 0.7, 0.0, pools=True)  # asphalt: wets all over, beams pool on it
FACADE_MATERIAL = Material(0.6, 0.85, 0.0, windows=True)
VEHICLE_MATERIAL = Material(0.2, 0.35, 0.12)  # paint and glass
# Roads are drawn before the rest of the opaque scene: the ground beneath them then fails the
# depth test before it is shaded (on llvmpipe a shaded pixel is the frame's cost).
ROAD_BIN, ROAD_BIN_SORT = "road_first", 15  # Panda3D's "opaque" bin sorts at 20


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
        self.boxes: ShadowBoxes | None = None
        self.headlights: Headlights | None = None
        self.street: StreetLights | None = None
        self.rain: Rain | None = None
        if not preset.shaded:
            return
        self._shaders: dict[tuple[bool, bool], Shader] = {}  # by (night, sun up), made on need
        _start_inputs(world)
        road.set_shader_input("surface", ROAD_MATERIAL.input())
        road.set_bin(_road_bin(), 0)
        for facade in _with_emission(road.get_parent()):
            facade.set_shader_input("surface", FACADE_MATERIAL.input())
        antialias = graphics.antialias()
        if antialias is not None:
            world.set_attrib(antialias)
        self.dome = SkyDome(world, preset, 0.5 * far_m, SHADOW_MASK)
        if preset.shadow_map_px:
            self.shadow = SunShadow(world, graphics, preset)
            if preset.box_shadows:
                self.boxes = ShadowBoxes(world, SHADOW_MASK)
        self.headlights = Headlights(world, preset)
        if preset.street_lights:
            self.street = StreetLights(world, road_map.lanes if road_map else [], bounds)
        if preset.rain_streaks:
            self.rain = Rain(world, preset)
        self._aim_sun()

    def vehicles(self, root: NodePath) -> None:
        """Give the actor layer's root the vehicles' material; where actors cast boxes'
        shadows, hide the actors themselves from the sun's camera."""
        if self.preset.shaded:
            root.set_shader_input("surface", VEHICLE_MATERIAL.input())
        if self.boxes is not None:
            root.hide(SHADOW_MASK)

    def update(self, frame: SceneFrame, head: NodePath, own: str | None) -> bool:
        """Light `frame` seen from `head`; True if the weather changed (the clear colour too)."""
        changed = self.weather.update(frame.weather, frame.t)
        if changed:
            self._aim_sun()
        if self.dome is not None:
            self.dome.follow(head)
        if self.shadow is not None:
            self.shadow.follow(head)
        if self.boxes is not None:
            self.boxes.update(frame.actors, own)
        if self.headlights is not None:
            self.headlights.update(frame.actors, head, own)
        if self.rain is not None:
            self.rain.update(self.weather.shown, frame.t)
        return changed

    def _aim_sun(self) -> None:
        if not self.preset.shaded:
            return
        day = self.weather.daylight
        if self.dome is not None:
            self.dome.aim(day.towards_sun)
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


def _with_emission(root: NodePath) -> list[NodePath]:
    """The geometry under `root` carrying a texture in emission mode (lit windows)."""
    found = []
    for geom_node in root.find_all_matches("**/+GeomNode"):
        node = geom_node.node()
        for i in range(node.get_num_geoms()):
            textures = node.get_geom_state(i).get_attrib(TextureAttrib)
            stages = [textures.get_on_stage(k) for k in range(textures.get_num_on_stages())
                      ] if textures else []  # fmt: skip
            if any(stage.get_mode() == TextureStage.M_emission for stage in stages):
                found.append(geom_node)
                break
    return found


def _road_bin() -> str:
    bins = CullBinManager.get_global_ptr()
    if bins.find_bin(ROAD_BIN) < 0:
        bins.add_bin(ROAD_BIN, CullBinManager.BT_state_sorted, ROAD_BIN_SORT)
    return ROAD_BIN


def _start_inputs(world: NodePath) -> None:
    """A start value for the inputs the surface shader reads that no room sets."""
    world.set_shader_input("surface", DEFAULT_MATERIAL.input())
    world.set_shader_input("wetness", 0.0)
    world.set_shader_input("clouds", Vec4(0, 0, 0, 0))
