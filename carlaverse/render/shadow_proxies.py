"""Actors' shadows for a software rasteriser: one box per actor, all in one mesh, seen only by
the sun's shadow camera.

An actor is a dozen nodes (body, glass, wheels, lamps); drawn again for the shadow map, 200 of
them cost llvmpipe as much as the whole picture. Their shadows do not need the detail: each
actor casts the shadow of its declared box (the protocol's extent, which its mesh fills), and
the boxes of every actor are one vertex array rewritten each frame — one draw call. The actor
the camera rides in casts none (its cockpit would sit in its own box's shade).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from panda3d.core import (
    BitMask32,
    Geom,
    GeomNode,
    GeomTriangles,
    GeomVertexData,
    GeomVertexFormat,
    NodePath,
    OmniBoundingVolume,
)

from carlaverse.render.frame import ActorDraw

# A unit box's corners (x across, y along, z up: bottom 0, top 1) and its 12 triangles.
CORNERS = np.array([(x, y, z) for z in (0.0, 1.0) for y in (-0.5, 0.5) for x in (-0.5, 0.5)])
FACES = (
    (0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
    (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5),
)  # fmt: skip


class ShadowBoxes:
    """Up to `capacity` actor boxes under `world`, drawn only by cameras in `casters`."""

    def __init__(self, world: NodePath, casters: BitMask32, capacity: int = 512) -> None:
        self.capacity = capacity
        self.data = GeomVertexData("shadow_boxes", GeomVertexFormat.get_v3(), Geom.UH_dynamic)
        self.data.unclean_set_num_rows(8 * capacity)
        tris = GeomTriangles(Geom.UH_static)
        for k in range(capacity):
            for a, b, c in FACES:
                tris.add_vertices(8 * k + a, 8 * k + b, 8 * k + c)
        geom = Geom(self.data)
        geom.add_primitive(tris)
        node = GeomNode("shadow_boxes")
        node.add_geom(geom)
        node.set_bounds(OmniBoundingVolume())  # the boxes move every frame: never culled
        node.set_final(True)
        self.node = world.attach_new_node(node)
        self.node.hide(BitMask32.all_on())
        self.node.show(casters)
        self.points = np.zeros((8 * capacity, 3), np.float32)

    def update(self, actors: Iterable[ActorDraw], own: str | None) -> None:
        boxes = [a for a in actors if a.actor_id != own][: self.capacity]
        self.points[:] = 0.0  # unused boxes shrink to a point: no area, no shadow
        if boxes:
            self.points[: 8 * len(boxes)] = corners(boxes).reshape(-1, 3)
        # An array is a buffer; the stubs' memoryview item assignment takes only bytes types.
        memoryview(self.data.modify_array(0)).cast("B").cast("f")[:] = self.points.ravel()  # type: ignore[call-overload]


def corners(actors: list[ActorDraw]) -> np.ndarray:
    """(n, 8, 3) world corners of each actor's box (its yaw; pitch and roll left out)."""
    size = np.array([(a.width, a.length, a.height) for a in actors])
    local = CORNERS[None, :, :] * size[:, None, :]
    yaw = np.array([a.yaw - math.pi / 2 for a in actors])  # the box's +y along the heading
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = c * local[..., 0] - s * local[..., 1]
    y = s * local[..., 0] + c * local[..., 1]
    origin = np.array([(a.x, a.y, a.z) for a in actors])
    return np.stack([x, y, local[..., 2]], axis=-1) + origin[:, None, :]
