"""Sign faces drawn in code (Pillow): speed limits, stop, give way, their backs, in one atlas.

Shapes and colours as Germany's StVO draws them: a speed limit (Zeichen 274) is a white disc
with a red ring an eighth of its diameter wide and the number in black; stop (Zeichen 206) a
red octagon with a white rim and STOP in white; give way (Zeichen 205) a white triangle,
point down, with a red rim. Outside the shape the atlas is transparent (alpha 0), so one
square quad per face draws any shape with an alpha test. Backs are the same shapes in grey.
Cell 0 is opaque white: poles take their colour from their vertices and sample it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

CELL_PX = 128  # [px] one face
COLUMNS = 4
RED = (200, 16, 24, 255)
WHITE = (245, 245, 242, 255)
BLACK = (20, 20, 20, 255)
GREY = (150, 152, 156, 255)
RING = 1 / 8  # of the diameter: the red ring of a round sign
MARGIN_PX = 3  # transparent border: mipmaps do not bleed one face into the next
SHAPE_SHARE = (CELL_PX - 2 * MARGIN_PX) / CELL_PX  # of a cell's side the shape spans


@dataclass(frozen=True, slots=True)
class Atlas:
    image: np.ndarray  # (h, w, 4) uint8, top row first
    cells: dict[str, tuple[float, float, float, float]]  # face -> u0, v0, u1, v1

    def uv(self, face: str) -> tuple[float, float, float, float]:
        return self.cells[face]


def face_name(kind: str, kmh: int = 0) -> str:
    return f"speed{kmh}" if kind == "speed" else kind


def back_name(kind: str) -> str:
    return {"speed": "back_round", "stop": "back_octagon", "yield": "back_triangle"}[kind]


def build_atlas(speeds: list[int]) -> Atlas:
    """Cells: white, stop, yield, the three backs, then one per speed limit (in km/h)."""
    faces = {
        "white": _fill(WHITE),
        "stop": stop_face(),
        "yield": yield_face(),
        "back_round": _round(GREY, GREY),
        "back_octagon": _octagon(GREY, GREY),
        "back_triangle": _triangle(GREY, GREY),
    }
    for kmh in sorted(set(speeds)):
        faces[face_name("speed", kmh)] = speed_face(kmh)
    rows = math.ceil(len(faces) / COLUMNS)
    image = Image.new("RGBA", (COLUMNS * CELL_PX, rows * CELL_PX), (0, 0, 0, 0))
    cells = {}
    w, h = image.size
    for k, (name, face) in enumerate(faces.items()):
        col, row = k % COLUMNS, k // COLUMNS
        image.paste(face, (col * CELL_PX, row * CELL_PX))
        # v counts from the bottom of the image (texture convention)
        u0, u1 = col * CELL_PX / w, (col + 1) * CELL_PX / w
        v1, v0 = 1 - row * CELL_PX / h, 1 - (row + 1) * CELL_PX / h
        cells[name] = (u0, v0, u1, v1)
    return Atlas(np.asarray(image), cells)


def speed_face(kmh: int) -> Image.Image:
    """Zeichen 274: the limit in black on white inside a red ring."""
    img = _round(RED, WHITE)
    text = str(kmh)
    size = CELL_PX * (0.42 if len(text) < 3 else 0.32)
    _centred_text(img, text, size, BLACK)
    return img


def stop_face() -> Image.Image:
    img = _octagon(WHITE, RED)
    _centred_text(img, "STOP", CELL_PX * 0.26, WHITE)
    return img


def yield_face() -> Image.Image:
    return _triangle(RED, WHITE)


def _fill(color: tuple[int, int, int, int]) -> Image.Image:
    return Image.new("RGBA", (CELL_PX, CELL_PX), color)


def _blank() -> tuple[Image.Image, ImageDraw.ImageDraw, float, float]:
    img = Image.new("RGBA", (CELL_PX, CELL_PX), (0, 0, 0, 0))
    lo, hi = MARGIN_PX, CELL_PX - 1 - MARGIN_PX
    return img, ImageDraw.Draw(img), lo, hi


def _round(rim: tuple[int, ...], inner: tuple[int, ...]) -> Image.Image:
    img, draw, lo, hi = _blank()
    draw.ellipse((lo, lo, hi, hi), fill=rim)
    ring = (hi - lo) * RING
    draw.ellipse((lo + ring, lo + ring, hi - ring, hi - ring), fill=inner)
    return img


def _octagon(rim: tuple[int, ...], inner: tuple[int, ...]) -> Image.Image:
    img, draw, lo, hi = _blank()
    c, r = (lo + hi) / 2, (hi - lo) / 2 / math.cos(math.pi / 8)  # flats touch the cell
    draw.polygon(_ngon(c, r, 8), fill=rim)
    draw.polygon(_ngon(c, r * 0.92, 8), fill=inner)
    return img


def _triangle(rim: tuple[int, ...], inner: tuple[int, ...]) -> Image.Image:
    img, draw, lo, hi = _blank()
    top = lo + (hi - lo) * (1 - math.sqrt(3) / 2)  # an equilateral triangle, point down
    draw.polygon([(lo, top), (hi, top), ((lo + hi) / 2, hi)], fill=rim)
    cx, cy, k = (lo + hi) / 2, (2 * top + hi) / 3, 0.62  # shrink towards the centroid
    inner_pts = [(cx + (x - cx) * k, cy + (y - cy) * k) for x, y in ((lo, top), (hi, top),
                 ((lo + hi) / 2, hi))]  # fmt: skip
    draw.polygon(inner_pts, fill=inner)
    return img


def _ngon(c: float, r: float, n: int) -> list[tuple[float, float]]:
    return [(c + r * math.cos(math.pi / n + k * math.tau / n),
             c + r * math.sin(math.pi / n + k * math.tau / n)) for k in range(n)]  # fmt: skip


def _centred_text(img: Image.Image, text: str, size: float, color: tuple[int, ...]) -> None:
    draw = ImageDraw.Draw(img)
    font = ImageFont.load_default(size=size)
    x0, y0, x1, y1 = draw.textbbox((0, 0), text, font=font)
    pos = ((CELL_PX - (x1 - x0)) / 2 - x0, (CELL_PX - (y1 - y0)) / 2 - y0)
    draw.text(pos, text, font=font, fill=color)
