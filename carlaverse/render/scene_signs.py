"""Traffic signs in the scene: a pole and a face per `signs.Sign`, one mesh, one atlas texture.

Sizes are Germany's for roads in town (VwV-StVO, size 2): round and octagonal faces 0.60 m
across, the give-way triangle 0.90 m a side; the face's lower edge `MOUNT_M` above the ground.
A face is a square quad cut to its shape by the atlas's alpha (an alpha test, no sorting),
with a grey back of the same shape facing the other way.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from panda3d.core import TransparencyAttrib

from carlaverse.render import palette
from carlaverse.render.meshes import MeshBuilder, Point2
from carlaverse.render.sign_faces import SHAPE_SHARE, back_name, build_atlas, face_name
from carlaverse.render.signs import Sign
from carlaverse.render.textures import texture

FACE_M = {"speed": 0.60, "stop": 0.60, "yield": 0.90}  # [m] the face's width
MOUNT_M = 2.0  # [m] from the ground to a face's lower edge
POLE_RADIUS_M = 0.038  # [m] a 76 mm pole
FACE_OFFSET_M = 0.05  # [m] the face in front of the pole's axis
POLE_TOP = 0.5  # of the face's half height above its middle: hidden behind any shape
WHITE = (1.0, 1.0, 1.0, 1.0)


def build_signs(signs: Sequence[Sign]) -> MeshBuilder:
    """All signs of the map as one mesh on one texture atlas."""
    atlas = build_atlas([s.kmh for s in signs if s.kind == "speed"])
    mesh = MeshBuilder("signs", texture("sign_faces", atlas.image))
    mesh.add_attrib(TransparencyAttrib.make(TransparencyAttrib.M_binary))
    white = _centre(atlas.uv("white"))
    for sign in signs:
        # the square quad is larger than the shape by the cell's transparent margin; both are
        # centred on the same point, the shape's lower edge MOUNT_M up
        quad = FACE_M[sign.kind] / SHAPE_SHARE
        cx, cy, cz = face_centre(sign)
        _pole(mesh, (sign.x, sign.y), cz + POLE_TOP * FACE_M[sign.kind] / 2, white)
        _face(mesh, (cx, cy, cz), sign.facing, quad, atlas.uv(face_name(sign.kind, sign.kmh)))
        fx, fy = math.cos(sign.facing) * 0.01, math.sin(sign.facing) * 0.01  # 1 cm behind
        back = atlas.uv(back_name(sign.kind))
        _face(mesh, (cx - fx, cy - fy, cz), sign.facing + math.pi, quad, _mirrored(back))
    return mesh


def face_centre(sign: Sign) -> tuple[float, float, float]:
    """The middle of a sign's face [m]: of a round or octagonal face, its centre."""
    fx, fy = math.cos(sign.facing) * FACE_OFFSET_M, math.sin(sign.facing) * FACE_OFFSET_M
    return (sign.x + fx, sign.y + fy, MOUNT_M + FACE_M[sign.kind] / 2)


def _pole(mesh: MeshBuilder, at: Point2, top: float, uv: Point2) -> None:
    ring = [(at[0] + POLE_RADIUS_M * math.cos(k * math.pi / 3),
             at[1] + POLE_RADIUS_M * math.sin(k * math.pi / 3)) for k in range(6)]  # fmt: skip
    for a, b in zip(ring, ring[1:] + ring[:1], strict=True):
        mesh.quad((*a, 0.0), (*b, 0.0), (*b, top), (*a, top), palette.SIGN_POLE, [uv] * 4)


def _face(mesh: MeshBuilder, centre: tuple[float, float, float], facing: float, size: float,
          uv: tuple[float, float, float, float]) -> None:  # fmt: skip
    """A square facing `facing`, its texture upright to someone looking at it."""
    rx, ry = -math.sin(facing) * size / 2, math.cos(facing) * size / 2  # the viewer's right
    cx, cy, cz = centre
    h = size / 2
    u0, v0, u1, v1 = uv
    corners = ((cx - rx, cy - ry, cz - h), (cx + rx, cy + ry, cz - h),
               (cx + rx, cy + ry, cz + h), (cx - rx, cy - ry, cz + h))  # fmt: skip
    mesh.quad(*corners, WHITE, [(u0, v0), (u1, v0), (u1, v1), (u0, v1)])


def _centre(uv: tuple[float, float, float, float]) -> Point2:
    return ((uv[0] + uv[2]) / 2, (uv[1] + uv[3]) / 2)


def _mirrored(uv: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """Backs are symmetric shapes; mirrored so the shape lines up with the front from behind."""
    return (uv[2], uv[1], uv[0], uv[3])
