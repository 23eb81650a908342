"""What each actor kind looks like: one prototype mesh per kind, and where its lamps sit.

A prototype is built in a unit frame (x across −0.5..0.5, y along −0.5..0.5 with +y forward,
z up 0..1) that the actor layer scales to an actor's extent, so 200 cars share one mesh. The
unit box is the protocol's bounding box: whatever a kind is made of — body, glass, wheels,
handlebar, lamps — reaches the box's faces and none goes beyond, and every vehicle rests on
its wheels at z = 0, the road under the actor's reference point.

Wheels are given in metres for the kind's typical extent (`KIND_EXTENTS`) and converted to
the unit frame, so they come out round at that extent (and a little oval for an actor whose
own extent has other proportions: its wheels still touch the road).
"""

from __future__ import annotations

from dataclasses import dataclass

from panda3d.core import NodePath

from carlaverse.messages import KIND_EXTENTS
from carlaverse.render import palette
from carlaverse.render.meshes import Color, MeshBuilder

# A box in the unit frame: (x, y, z) of its bottom face's centre, and its (sx, sy, sz).
Box = tuple[tuple[float, float, float], tuple[float, float, float]]

LAMP_KINDS = {"car", "van", "truck", "bus", "motorcycle"}
# Lamps are flush with the box's ends (their outer faces at y = ±0.5, where the body's end
# faces are too); the actor layer draws them with a depth offset so they win that tie.
BRAKE_LAMPS: tuple[Box, ...] = (
    ((-0.36, -0.49, 0.42), (0.18, 0.02, 0.1)),
    ((0.36, -0.49, 0.42), (0.18, 0.02, 0.1)),
)
LEFT_BLINKERS: tuple[Box, ...] = (
    ((-0.44, 0.49, 0.38), (0.1, 0.02, 0.07)),
    ((-0.455, -0.49, 0.56), (0.08, 0.02, 0.07)),
)
RIGHT_BLINKERS: tuple[Box, ...] = (
    ((0.44, 0.49, 0.38), (0.1, 0.02, 0.07)),
    ((0.455, -0.49, 0.56), (0.08, 0.02, 0.07)),
)


@dataclass(frozen=True, slots=True)
class Wheels:
    """A kind's wheels at its typical extent."""

    radius_m: float  # [m] to the tread
    tyre_m: float  # [m] tread width
    axles: tuple[float, ...]  # along the length from its middle, as a fraction of it (+ ahead)
    paired: bool  # a wheel at each side of an axle (else one, in line: a two-wheeler)


# Typical sizes: a car on 205/55 R16 (0.32 m), a van on 16" light-truck tyres, a truck and a
# city bus on 22.5" (0.5 m), a motorcycle on 17" (0.3 m), a bicycle on 700C (0.34 m); the
# axles give wheelbases of 2.7 m, 3.4 m, 5.4 m (front to the rear tandem's middle), 6.0 m,
# 1.4 m and 1.0 m.
WHEELS: dict[str, Wheels] = {
    "car": Wheels(0.32, 0.20, (0.3, -0.3), paired=True),
    "van": Wheels(0.35, 0.22, (0.33, -0.33), paired=True),
    "truck": Wheels(0.5, 0.3, (0.36, -0.24, -0.37), paired=True),
    "bus": Wheels(0.5, 0.3, (0.28, -0.22), paired=True),
    "motorcycle": Wheels(0.3, 0.12, (0.33, -0.33), paired=False),
    "bicycle": Wheels(0.34, 0.05, (0.28, -0.28), paired=False),
}
WHEEL_INSET = 0.02  # a paired wheel's outer face this far inside the box's side (unit frame)


def _shape(kind: str, body: Color) -> list[tuple[Box, Color]]:
    """The boxes that make up one kind, in the unit frame (its wheels come on top)."""
    g, skin, tyre = palette.GLASS, palette.SKIN, palette.TYRE
    shapes: dict[str, list[tuple[Box, Color]]] = {
        "car": [
            (((0, 0, 0.12), (1.0, 1.0, 0.45)), body),
            (((0, -0.05, 0.57), (0.86, 0.5, 0.43)), g),
        ],
        # a windscreen reaches the front; the body under it stops just short (no coplanar faces)
        "van": [
            (((0, -0.0025, 0.1), (1.0, 0.995, 0.9)), body),
            (((0, 0.455, 0.55), (0.9, 0.09, 0.3)), g),
        ],
        "truck": [
            (((0, 0.3775, 0.08), (1.0, 0.235, 0.8)), body),
            (((0, 0.475, 0.5), (0.9, 0.05, 0.25)), g),
            (((0, -0.13, 0.1), (1.0, 0.74, 0.9)), palette.BUILDING),
        ],
        "bus": [(((0, 0, 0.08), (0.98, 1.0, 0.92)), body), (((0, 0, 0.55), (1.0, 0.94, 0.25)), g)],
        "motorcycle": [
            (((0, 0, 0.12), (0.35, 1.0, 0.4)), body),
            (((0, -0.1, 0.5), (0.8, 0.3, 0.35)), g),
            (((0, -0.1, 0.85), (0.5, 0.2, 0.15)), skin),
            (((0, 0.3, 0.6), (1.0, 0.04, 0.04)), tyre),  # handlebar and mirrors: the width
        ],
        "bicycle": [
            (((0, 0, 0.1), (0.2, 1.0, 0.45)), body),
            (((0, -0.05, 0.5), (0.8, 0.25, 0.35)), body),
            (((0, -0.05, 0.85), (0.45, 0.2, 0.15)), skin),
            (((0, 0.22, 0.57), (1.0, 0.03, 0.03)), tyre),  # handlebar: the width
        ],
        "pedestrian": [
            (((0, 0, 0), (0.6, 0.6, 0.45)), tyre),
            (((0, 0, 0.45), (1.0, 0.8, 0.4)), body),
            (((0, 0, 0.86), (0.5, 0.5, 0.14)), skin),
        ],
    }
    return shapes.get(kind, [(((0, 0, 0), (1.0, 1.0, 1.0)), body)])


def _add_wheels(mesh: MeshBuilder, kind: str) -> None:
    wheels = WHEELS.get(kind)
    if wheels is None:
        return
    typical = KIND_EXTENTS[kind]
    ry, rz = wheels.radius_m / typical.length, wheels.radius_m / typical.height
    tyre = wheels.tyre_m / typical.width
    across = (-0.5 + WHEEL_INSET + tyre / 2, 0.5 - WHEEL_INSET - tyre / 2)
    for along in wheels.axles:
        for x in across if wheels.paired else (0.0,):
            mesh.cylinder_x((x, along, rz), tyre, (ry, rz), palette.TYRE)


def prototype(kind: str, ego: bool) -> NodePath:
    """One kind's mesh in the unit frame; an ego's a little brighter than an NPC's."""
    body = palette.ACTOR_COLORS.get(kind, palette.ACTOR_COLORS["other"])
    if ego:
        body = (*(min(1.0, c * palette.EGO_TINT) for c in body[:3]), 1.0)
    mesh = MeshBuilder(f"actor/{kind}")
    for (center, size), color in _shape(kind, body):
        mesh.box(center, size, color)
    _add_wheels(mesh, kind)
    return NodePath(mesh.node())


def lamp_prototype() -> NodePath:
    """A unit box, white: each lamp instances it, scaled and coloured per actor."""
    mesh = MeshBuilder("lamp")
    mesh.box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0))
    return NodePath(mesh.node())
