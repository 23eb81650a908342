"""The scene's light, put together per quality preset: shading, sky, sun, night, rain.

`SceneLighting` owns every room that lights the world and calls them once per frame:

- `weather` (sun, sky and fog numbers, fixed-function for `flat`, shader inputs otherwise),
- `sky_dome` (the sky drawn around the eye), `shadows` (the sun's shadow map) and
  `shadow_proxies` (actors' boxes in it, where the preset says so),
- `headlights` (spotlights and glare from the vehicles' lamp bits), `street_lights`
  (poles and their baked light), `rain` (streaks around the eye).

The surface shader (`shaders.surfaces`) goes on the world node, so everything under it —
map, actors, signal heads — is lit the same way; a node tunes its material with the
`surface` input (wet response, roughness, flags, gloss). Lit per vertex (`cpu`), a node whose
material has flags also gets a program with them compiled in (llvmpipe would run a flag's
branch for every pixel of the frame): `flagged` keeps those nodes and their flags.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from panda3d.core import (
    CullBinManager,
    GeomNode,
    NodePath,
    Shader,
    TextureAttrib,
    TextureStage,
    Vec4,
)

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
    untextured: bool = False  # no texture to fetch (a pixel's fetch is dear on llvmpipe)

    def flags(self) -> int:
        """The flags of `shaders.defines`: POOLS 1, WINDOWS 2, UNTEXTURED 4 (LAMP 8: `lamps`)."""
        flags = (1 if self.pools else 0) | (2 if self.windows else 0)
        return flags | (4 if self.untextured else 0)

    def input(self) -> Vec4:
        return Vec4(self.wet_response, self.roughness, float(self.flags()), self.gloss)

    def of(self, node: NodePath) -> Material:
        """This material with the flags `node`'s own textures set (its first geom's)."""
        stages = _stages(node)
        return replace(
            self,
            windows=any(s.get_mode() == TextureStage.M_emission for s in stages),
            untextured=not any(s.get_mode() == TextureStage.M_modulate for s in stages),
        )


DEFAULT_MATERIAL = Material(0.6, 0.85, 0.0)  # ground, walls, roofs: matte, partly puddled
ROAD_MATERIAL = Material(1.0, 0.7, 0.0, pools=True)  # asphalt: wets all over, beams pool on it
VEHICLE_MATERIAL = Material(0.2, 0.35, 0.12, untextured=True)  # paint and glass
# The own vehicle seen from inside: its dashboard faces up under the roof, where no rain falls,
# and wetness acts on every upward face, so the cabin takes none (the bonnet stays dry too: one
# mesh, and a dry bonnet is the smaller error than a dashboard mirroring the sky).
OWN_VEHICLE_MATERIAL = Material(0.0, 0.35, 0.12, untextured=True)
# Roads are drawn before the rest of the opaque scene: the ground beneath them then fails the
# depth test before it is shaded (on llvmpipe a shaded pixel is the frame's cost).
ROAD_BIN, ROAD_BIN_SORT = "road_first", 15  # Panda3D's "opaque" bin sorts at 20
LAMP_FLAG = 8  # `shaders.defines`' LAMP: a program that only glows
FLAT_M = 0.3  # [m] geometry no taller casts no shadow worth a pass (ground, roads, kerbs)


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
        # by (night, sun up, flags compiled in, wet), made on need
        self._shaders: dict[tuple[bool, bool, int | None, bool], Shader] = {}
        self._flagged: list[tuple[NodePath, int]] = []  # nodes with a program of their own
        _start_inputs(world)
        for node, material in _materials(road.get_parent(), road):
            self._flag(node, material)
        road.set_bin(_road_bin(), 0)
        antialias = graphics.antialias()
        if antialias is not None:
            world.set_attrib(antialias)
        self.dome = SkyDome(world, preset, 0.5 * far_m, SHADOW_MASK)
        if preset.shadow_map_px:
            self.shadow = SunShadow(world, graphics, preset)
            for flat in _flat_parts(road.get_parent()):  # ground, roads, paint, kerbs
                flat.hide(SHADOW_MASK)
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
            self._flag(root, VEHICLE_MATERIAL)
            self._aim_sun()
        if self.boxes is not None:
            root.hide(SHADOW_MASK)

    def lamps(self, prototype: NodePath) -> None:
        """Give the vehicles' lamp prototype a program of its own where light is per vertex: a
        lamp glows whatever the light, and its vertices (a tenth of a car's) skip lighting."""
        if self.preset.shaded and not self.preset.per_pixel:
            self._flagged.append((prototype, VEHICLE_MATERIAL.flags() | LAMP_FLAG))
            self._aim_sun()

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
        night, sun_up = day.night > 0.0, day.towards_sun[2] > SUN_UP_Z
        wet = self.weather.shown.wetness > 0.0  # the shaders' wetness input is clamped to 0..1
        compiled = None if self.preset.per_pixel else 0
        self.world.set_shader(self._shader(night, sun_up, compiled, wet))
        for node, flags in self._flagged:
            node.set_shader(self._shader(night, sun_up, flags, wet))
        if self.shadow is not None:
            self.shadow.aim(day.towards_sun)
        if self.street is not None:
            self.street.night(day.night)

    def _shader(self, night: bool, sun_up: bool, flags: int | None, wet: bool) -> Shader:
        key = (night, sun_up, flags, wet)
        if key not in self._shaders:
            self._shaders[key] = Shader.make(Shader.SL_GLSL, *surface_sources(self.preset, *key))
        return self._shaders[key]

    def _flag(self, node: NodePath, material: Material) -> None:
        """Give `node` a program with its material's flags compiled in (lit per vertex)."""
        if not self.preset.per_pixel and material.flags():
            self._flagged.append((node, material.flags()))

    def close(self) -> None:
        if self.shadow is not None:
            self.shadow.close()


def _flat_parts(root: NodePath) -> list[NodePath]:
    """The geometry under `root` no taller than FLAT_M: its shadow is too short to see, and
    drawn for the sun's camera each frame it would cost a second pass over the whole map."""
    flat = []
    for geom_node in root.find_all_matches("**/+GeomNode"):
        bounds = geom_node.get_tight_bounds()
        if bounds is not None and bounds[1].z - bounds[0].z < FLAT_M:
            flat.append(geom_node)
    return flat


def _materials(static: NodePath, road: NodePath) -> list[tuple[NodePath, Material]]:
    """Each mesh of the map gets its material, flagged by the textures it carries."""
    out = []
    for geom_node in static.find_all_matches("**/+GeomNode"):
        under_road = geom_node == road or road.is_ancestor_of(geom_node)
        material = (ROAD_MATERIAL if under_road else DEFAULT_MATERIAL).of(geom_node)
        geom_node.set_shader_input("surface", material.input())
        out.append((geom_node, material))
    return out


def _stages(node: NodePath) -> list[TextureStage]:
    """The texture stages on a GeomNode's first geom (a builder's mesh has one geom)."""
    geom_node = node.node()
    if not isinstance(geom_node, GeomNode) or geom_node.get_num_geoms() == 0:
        return []
    textures = geom_node.get_geom_state(0).get_attrib(TextureAttrib)
    if textures is None:
        return []
    return [textures.get_on_stage(k) for k in range(textures.get_num_on_stages())]


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
