"""Procedural textures: asphalt, paving, kerb stone, grass, paint, roofs, facades, lit windows.

Nothing is downloaded or shipped: each texture is computed from a seeded generator, so every
node that builds a map draws the same picture. A `Surface` pairs a texture with the metres one
repeat covers (geometry carries texture coordinates in metres, divided by that repeat) and with
the texture's mean colour, so that a tint of `palette colour / mean` keeps a surface's average
colour where the palette puts it: textures add detail, the palette keeps the look.

Facades are drawn in bays (one window per bay and floor) of `FLOOR_M` floors; the upper-floor
texture holds FACADE_BAYS × FACADE_FLOORS windows, the ground-floor texture FACADE_BAYS bays
with one door. Each has an emission twin — black, with the windows that are lit at night —
which the buildings carry on a texture stage of their own (`scene_buildings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from panda3d.core import SamplerState, Texture

from carlaverse.render.meshes import Color

FLOOR_M = 3.0  # [m] storey height of the facades
FACADE_BAYS = 4  # windows across one repeat of a facade texture
FACADE_FLOORS = 4  # floors in one repeat of the upper-floor texture
BAY_PX = 128  # [px] one bay and floor of a facade texture
LIT_SHARE = 0.4  # of the windows lit at night
LIT_WINDOW: Color = (1.0, 0.78, 0.45, 1.0)  # warm interior light


@dataclass(frozen=True, slots=True)
class Surface:
    """A texture, the metres one repeat covers (u, v) and its mean colour (RGB, 0..1); no
    texture (a plain set) draws the palette's colour as it is."""

    texture: Texture | None
    tile_m: tuple[float, float]
    mean: tuple[float, float, float]

    def tint(self, color: Color) -> Color:
        """The vertex colour that makes this surface average to `color`."""
        r, g, b = (min(1.0, c / max(m, 1e-6)) for c, m in zip(color[:3], self.mean, strict=True))
        return (r, g, b, color[3])


@dataclass(frozen=True, slots=True)
class TextureSet:
    """Every texture of the static scene, built once per map."""

    asphalt: Surface
    paving: Surface
    kerb: Surface
    grass: Surface
    paint: Surface
    roof: Surface
    facade: Surface  # upper floors; its tile is one bay wide per FACADE_BAYS, set per wall
    facade_lit: Texture | None  # the upper floors' lit windows, same layout
    ground_floor: Surface  # shop windows and a door
    ground_floor_lit: Texture | None


def texture_set(seed: int = 0, plain: bool = False) -> TextureSet:
    """All textures from one seed (the same seed gives the same pixels); `plain`: none at all,
    every surface in its palette colour (the cheapest picture for a software rasteriser)."""
    if plain:
        bare = Surface(None, (1.0, 1.0), (1.0, 1.0, 1.0))
        return TextureSet(bare, bare, bare, bare, bare, bare, bare, None, bare, None)
    rng = np.random.default_rng(seed)
    facade, facade_lit = facade_images(rng, FACADE_FLOORS, door=False)
    ground, ground_lit = facade_images(rng, 1, door=True)
    return TextureSet(
        asphalt=surface("asphalt", asphalt_image(rng), (4.0, 4.0)),
        paving=surface("paving", paving_image(rng), (2.4, 2.4)),
        kerb=surface("kerb", kerb_image(rng), (1.0, 0.25)),
        grass=surface("grass", grass_image(rng), (6.0, 6.0)),
        paint=surface("paint", paint_image(rng), (1.0, 1.0)),
        roof=surface("roof", roof_image(rng), (4.0, 4.0)),
        facade=surface("facade", facade, (1.0, 1.0)),
        facade_lit=texture("facade_lit", facade_lit),
        ground_floor=surface("ground_floor", ground, (1.0, 1.0)),
        ground_floor_lit=texture("ground_floor_lit", ground_lit),
    )


def surface(name: str, image: np.ndarray, tile_m: tuple[float, float]) -> Surface:
    mean = image.reshape(-1, image.shape[-1])[:, :3].mean(axis=0) / 255.0
    return Surface(texture(name, image), tile_m, (float(mean[0]), float(mean[1]), float(mean[2])))


def texture(name: str, image: np.ndarray) -> Texture:
    """A repeating, mipmapped texture from an (h, w, 3|4) uint8 image, top row first.

    Stored as RGBA even when opaque: Mesa's llvmpipe samples 32-bit texels on its fast path
    (measured: the town's frame 10 % cheaper than with 24-bit RGB)."""
    if image.shape[2] == 3:
        image = np.concatenate([image, np.full((*image.shape[:2], 1), 255, np.uint8)], axis=2)
    h, w, channels = image.shape
    tex = Texture(name)
    fmt = Texture.F_rgba if channels == 4 else Texture.F_rgb
    tex.setup_2d_texture(w, h, Texture.T_unsigned_byte, fmt)
    # Panda3D keeps rows bottom first and channels as BGR(A)
    order = [2, 1, 0, 3][:channels]
    tex.set_ram_image(np.ascontiguousarray(image[::-1, :, order]).tobytes())
    tex.set_wrap_u(SamplerState.WM_repeat)
    tex.set_wrap_v(SamplerState.WM_repeat)
    # mipmaps: no shimmer at a distance; one level per pixel (not trilinear) is cheaper on a CPU
    tex.set_minfilter(SamplerState.FT_linear_mipmap_nearest)
    tex.set_magfilter(SamplerState.FT_linear)
    return tex


# ------------------------------------------------------------------ images


def tileable_noise(rng: np.random.Generator, size: int, cells: int) -> np.ndarray:
    """Value noise in 0..1 on a (size, size) grid that wraps seamlessly (cells per side)."""
    grid = rng.random((cells, cells))
    t = np.arange(size) * cells / size
    i0 = np.floor(t).astype(int)
    f = t - i0
    f = f * f * (3 - 2 * f)  # smoothstep: no creases along the cell edges
    i1 = (i0 + 1) % cells
    rows = grid[i0][:, i0] * (1 - f)[None, :] + grid[i0][:, i1] * f[None, :]
    rows_next = grid[i1][:, i0] * (1 - f)[None, :] + grid[i1][:, i1] * f[None, :]
    return rows * (1 - f)[:, None] + rows_next * f[:, None]


def _octaves(rng: np.random.Generator, size: int, cells: tuple[int, ...]) -> np.ndarray:
    total = sum(tileable_noise(rng, size, c) / (k + 1) for k, c in enumerate(cells))
    return np.asarray(total / sum(1 / (k + 1) for k in range(len(cells))))


def _grey(values: np.ndarray) -> np.ndarray:
    return np.repeat(_u8(values)[..., None], 3, axis=2)


def _u8(values: np.ndarray) -> np.ndarray:
    return np.clip(np.round(values * 255), 0, 255).astype(np.uint8)


def asphalt_image(rng: np.random.Generator, size: int = 256) -> np.ndarray:
    """Worn asphalt: broad patches, fine grain and light aggregate stones."""
    base = 0.62 + 0.12 * (_octaves(rng, size, (4, 16)) - 0.5)
    grain = 0.10 * (rng.random((size, size)) - 0.5)
    stones = (rng.random((size, size)) < 0.04) * 0.22 - (rng.random((size, size)) < 0.03) * 0.15
    return _grey(base + grain + stones)


def paving_image(rng: np.random.Generator, size: int = 256, slabs: int = 8) -> np.ndarray:
    """Concrete slabs (8 × 8 to a repeat of 2.4 m: 30 cm each) with dark joints."""
    cell = size // slabs
    shade = 0.78 + 0.05 * (rng.random((slabs, slabs)) - 0.5)
    values = np.kron(shade, np.ones((cell, cell))) + 0.06 * (rng.random((size, size)) - 0.5)
    values += 0.05 * (_octaves(rng, size, (8,)) - 0.5)
    joint = (np.arange(size) % cell) < 2
    values[joint, :] *= 0.6
    values[:, joint] *= 0.6
    return _grey(values)


def kerb_image(rng: np.random.Generator, width: int = 128, height: int = 32) -> np.ndarray:
    """Kerb stones of 1 m (one repeat), light concrete with a joint at each end."""
    values = 0.82 + 0.06 * (rng.random((height, width)) - 0.5)
    values[:, :2] *= 0.55
    return _grey(values)


def grass_image(rng: np.random.Generator, size: int = 256) -> np.ndarray:
    """Lawn: green with drier and darker patches and blade-scale speckle."""
    patches = _octaves(rng, size, (4, 16))
    blades = rng.random((size, size))
    g = 0.55 + 0.14 * (patches - 0.5) + 0.18 * (blades - 0.5)
    r = 0.5 * g + 0.10 * (patches - 0.5) + 0.05
    b = 0.30 * g
    return np.stack([_u8(r), _u8(g), _u8(b)], axis=2)


def paint_image(rng: np.random.Generator, size: int = 64) -> np.ndarray:
    """Road paint: white, a little worn."""
    return _grey(0.93 + 0.07 * (_octaves(rng, size, (8, 32)) - 0.5))


def roof_image(rng: np.random.Generator, size: int = 128) -> np.ndarray:
    """Flat roof: gravel."""
    return _grey(
        0.55 + 0.2 * (rng.random((size, size)) - 0.5) + 0.1 * (_octaves(rng, size, (8,)) - 0.5)
    )


def facade_images(
    rng: np.random.Generator, floors: int, door: bool
) -> tuple[np.ndarray, np.ndarray]:
    """A facade (plaster, framed windows; a door in bay 1 when `door`) and its lit windows."""
    h, w = floors * BAY_PX, FACADE_BAYS * BAY_PX
    plaster = 0.86 + 0.05 * (_octaves(rng, max(h, w), (8, 32))[:h, :w] - 0.5)
    colour = _grey(plaster).astype(float) / 255
    lit = np.zeros((h, w, 3))
    for floor in range(floors):
        for bay in range(FACADE_BAYS):
            top = (floors - 1 - floor) * BAY_PX  # rows count from the top, floors from the ground
            cell = (slice(top, top + BAY_PX), slice(bay * BAY_PX, (bay + 1) * BAY_PX))
            if door and bay == 1:
                _draw_door(colour[cell], lit[cell])
            else:
                shop = door  # the ground floor has larger windows
                _draw_window(colour[cell], lit[cell], shop, rng.random() < LIT_SHARE)
    return _u8(colour), _u8(lit)


def _box(img: np.ndarray, x0: float, x1: float, y0: float, y1: float) -> tuple[slice, slice]:
    """Rows and columns of a box given in bay fractions (x from the left, y from the floor)."""
    n = img.shape[0]
    return slice(round((1 - y1) * n), round((1 - y0) * n)), slice(round(x0 * n), round(x1 * n))


def _draw_window(cell: np.ndarray, lit: np.ndarray, shop: bool, on: bool) -> None:
    """A framed window: sill at 0.3 of the floor (0.9 m), head at 0.8 (2.4 m)."""
    x0, x1, y0, y1 = (0.12, 0.88, 0.12, 0.85) if shop else (0.25, 0.75, 0.30, 0.80)
    cell[_box(cell, x0 - 0.03, x1 + 0.03, y0 - 0.04, y0)] = 0.95  # the sill
    cell[_box(cell, x0, x1, y0, y1)] = 0.92  # the frame
    glass = _box(cell, x0 + 0.03, x1 - 0.03, y0 + 0.03, y1 - 0.03)
    rows = cell[glass].shape[0]
    sky = np.linspace(0.34, 0.16, rows)[:, None]  # reflections: brighter at the top
    cell[glass] = np.stack([sky * 0.85, sky * 0.95, sky * 1.1], axis=2)
    mid = round((x0 + x1) / 2 * cell.shape[1])
    cell[glass[0], mid - 2 : mid + 2] = 0.92  # the mullion
    if on:
        lit[glass] = LIT_WINDOW[:3]
        lit[glass[0], mid - 2 : mid + 2] = 0.0


def _draw_door(cell: np.ndarray, lit: np.ndarray) -> None:
    """A wooden door 0.4 of a bay wide (1.3 m at 3.2 m bays), 0.73 of the floor (2.2 m)."""
    cell[_box(cell, 0.27, 0.73, 0.0, 0.77)] = 0.9  # the frame
    cell[_box(cell, 0.30, 0.70, 0.0, 0.73)] = (0.36, 0.22, 0.12)
    pane = _box(cell, 0.38, 0.62, 0.42, 0.66)
    cell[pane] = (0.2, 0.22, 0.26)
    lit[pane] = LIT_WINDOW[:3]
