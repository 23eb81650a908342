"""Street lights along the roads: poles from the map's lanes, and their light baked in a map.

Poles stand beside the rightmost lane of every edge (SUMO index 0: the kerb side), every
SPACING_M along it, with an arm reaching over the road; each edge's own side, so a two-way
street is lit from both. A town has hundreds; lighting them one by one per pixel would cost a
GPU dear and llvmpipe everything, so their light on the ground is baked once into a float
texture over the map: at a point r from the foot of a lamp h high, E = I·h/(h² + r²)^(3/2)
(inverse square times the cosine of incidence on a level surface), summed over lamps. The
surface shader reads it at a fragment's (x, y), times night (`sky.night_level`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

import numpy as np
from panda3d.core import NodePath, SamplerState, Texture, Vec4

from carlaverse.messages import MapLane
from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, Point2

SPACING_M = 32.0  # [m] between poles along a road (urban, EN 13201 classes M/C ~ 3–4 × h)
FIRST_M = 10.0  # [m] the first pole after the lane's start
LAMP_HEIGHT_M = 7.5  # [m]
ARM_M = 1.6  # [m] from the pole over the road
KERB_GAP_M = 0.5  # [m] the pole's distance outside the lane's right edge
LAMP_I = 3.0  # intensity, relative units: 0.053 under the lamp, ~1/10 of that 15 m away
REACH_M = 28.0  # [m] beyond this a lamp's light is below 1 % of its peak and not baked
TEXEL_M = 0.5  # [m] baked map resolution, coarser for big maps
MAX_TEXELS = 2048  # per side of the baked map
MAX_POLES = 4000
LAMP_DAY: tuple[float, float, float] = (0.55, 0.55, 0.52)
LAMP_NIGHT: tuple[float, float, float] = (1.0, 0.88, 0.66)


def pole_sites(lanes: Iterable[MapLane]) -> list[tuple[Point2, Point2]]:
    """(foot of the pole, point under the lamp) for every street light, at most MAX_POLES."""
    sites: list[tuple[Point2, Point2]] = []
    for lane in lanes:
        if lane.id.startswith(":") or not lane.id.endswith("_0") or len(lane.centerline) < 2:
            continue
        if lane.kind not in ("road", "sidewalk", "bike"):
            continue
        out = lane.width / 2 + KERB_GAP_M
        for (x, y), (dx, dy) in stations(lane.centerline, FIRST_M, SPACING_M):
            foot = (x + dy * out, y - dx * out)  # (dy, -dx) points to the right
            sites.append((foot, (foot[0] - dy * ARM_M, foot[1] + dx * ARM_M)))
            if len(sites) >= MAX_POLES:
                return sites
    return sites


def stations(line: Sequence[Point2], first: float, spacing: float
             ) -> list[tuple[Point2, Point2]]:  # fmt: skip
    """Points every `spacing` [m] along a polyline from `first`, with the unit direction there."""
    out = []
    at, walked = first, 0.0
    for (x0, y0), (x1, y1) in itertools.pairwise(line):
        step = math.hypot(x1 - x0, y1 - y0)
        if step < 1e-9:
            continue
        while at <= walked + step:
            u = (at - walked) / step
            out.append(
                ((x0 + (x1 - x0) * u, y0 + (y1 - y0) * u), ((x1 - x0) / step, (y1 - y0) / step))
            )
            at += spacing
        walked += step
    return out


def pole_meshes(sites: Sequence[tuple[Point2, Point2]]) -> tuple[MeshBuilder, MeshBuilder]:
    """The poles with their arms (lit like the scene), and the lamp heads (emissive)."""
    poles, heads = MeshBuilder("street_poles"), MeshBuilder("street_lamps")
    for (fx, fy), (lx, ly) in sites:
        poles.box((fx, fy, 0.0), (0.16, 0.16, LAMP_HEIGHT_M + 0.2), palette.POLE)
        n = max(1, round(ARM_M / 0.2))
        for k in range(n + 1):  # the arm: small boxes from the pole to the lamp
            u = k / n
            poles.box((fx + (lx - fx) * u, fy + (ly - fy) * u, LAMP_HEIGHT_M + 0.1),
                      (0.1, 0.1, 0.1), palette.POLE)  # fmt: skip
        heads.box((lx, ly, LAMP_HEIGHT_M - 0.08), (0.45, 0.45, 0.12), (1.0, 1.0, 1.0, 1.0))
    return poles, heads


class StreetLights:
    """The poles, the lamps (glowing at night) and the baked light, under `world`."""

    def __init__(self, world: NodePath, lanes: Iterable[MapLane],
                 bounds: tuple[float, float, float, float]) -> None:  # fmt: skip
        self.sites = pole_sites(lanes)
        poles, heads = pole_meshes(self.sites)
        self.root = world.attach_new_node("street_lights")
        if not poles.empty:
            self.root.attach_new_node(poles.node())
        self.heads = self.root.attach_new_node(heads.node()) if not heads.empty else None
        if self.heads is not None:
            self.heads.set_light_off(1)  # emissive
        self.root.flatten_strong()
        light, rect = bake([site[1] for site in self.sites], bounds)
        world.set_shader_input("street_map", light)
        world.set_shader_input("street_rect", rect)
        self.night(0.0)

    def night(self, level: float) -> None:
        """Lamp heads glow from `level` 0 (day, grey glass) to 1 (fully on)."""
        if self.heads is None:
            return
        c = [d + (n - d) * level for d, n in zip(LAMP_DAY, LAMP_NIGHT, strict=True)]
        self.heads.set_color(c[0], c[1], c[2], 1.0)


def bake(lamps: Sequence[Point2], bounds: tuple[float, float, float, float]
         ) -> tuple[Texture, Vec4]:  # fmt: skip
    """The lamps' ground irradiance as a float texture, and its rect (x0, y0, 1/w, 1/h)."""
    xmin, ymin, xmax, ymax = bounds
    xmin, ymin, xmax, ymax = xmin - REACH_M, ymin - REACH_M, xmax + REACH_M, ymax + REACH_M
    texel = max(TEXEL_M, (xmax - xmin) / MAX_TEXELS, (ymax - ymin) / MAX_TEXELS)
    nx, ny = max(2, math.ceil((xmax - xmin) / texel)), max(2, math.ceil((ymax - ymin) / texel))
    grid = ground_irradiance(lamps, xmin, ymin, texel, nx, ny)
    tex = Texture("street_light")
    tex.setup_2d_texture(nx, ny, Texture.T_float, Texture.F_r32)
    tex.set_ram_image(grid.astype(np.float32).tobytes())
    tex.set_wrap_u(SamplerState.WM_clamp)
    tex.set_wrap_v(SamplerState.WM_clamp)
    tex.set_minfilter(SamplerState.FT_linear)
    tex.set_magfilter(SamplerState.FT_linear)
    return tex, Vec4(xmin, ymin, 1.0 / (nx * texel), 1.0 / (ny * texel))


def ground_irradiance(lamps: Sequence[Point2], x0: float, y0: float, texel: float,
                      nx: int, ny: int) -> np.ndarray:  # fmt: skip
    """(ny, nx) irradiance at texel centres: row j is y = y0 + (j + ½)·texel."""
    grid = np.zeros((ny, nx), np.float64)
    reach = math.ceil(REACH_M / texel)
    h = LAMP_HEIGHT_M
    for lx, ly in lamps:
        ci, cj = int((lx - x0) / texel), int((ly - y0) / texel)
        i0, i1 = max(0, ci - reach), min(nx, ci + reach + 1)
        j0, j1 = max(0, cj - reach), min(ny, cj + reach + 1)
        if i0 >= i1 or j0 >= j1:
            continue
        xs = x0 + (np.arange(i0, i1) + 0.5) * texel - lx
        ys = y0 + (np.arange(j0, j1) + 0.5) * texel - ly
        r2 = ys[:, None] ** 2 + xs[None, :] ** 2
        grid[j0:j1, i0:i1] += LAMP_I * h / (h * h + r2) ** 1.5
    return grid
