"""Meshes of the own vehicle as its rider sees it: a car's cockpit, a bicycle's handlebar.

Built once from the config (`own_config`) in the rig anchor's frame — Panda3D's actor frame,
x right, y forward, z up, in metres from the vehicle's reference point on the road — so they
move with the vehicle and not with the head. The config's vehicle frame (x forward, y left)
maps to it by `panda()`.

The cockpit: a bonnet crowned along its middle whose corners fall away towards the front, a
dashboard with an instrument binnacle in front of the driver, the doors' tops up to the belt
line, two A-pillars from the scuttle to the roof, a header rail and the roof. The handlebar: a
stem rising from the head tube to a swept-back bar with grips.
"""

from __future__ import annotations

from carlaverse.render.meshes import Color, MeshBuilder, Point3
from carlaverse.render.own_config import XYZ, Cockpit, Handlebar
from carlaverse.render.rig import HeadPosition
from carlaverse.render.shapes import beam, facing

DASH: Color = (0.09, 0.09, 0.10, 1.0)
TRIM: Color = (0.16, 0.16, 0.17, 1.0)  # pillars, doors, headlining
SCUTTLE: Color = (0.04, 0.04, 0.04, 1.0)
BAR: Color = (0.55, 0.56, 0.58, 1.0)
GRIP: Color = (0.06, 0.06, 0.06, 1.0)
HOOD_CROWN_M = 0.03  # [m] the bonnet's middle above its sides
HOOD_CORNER_DROP_M = 0.05  # [m] how far its front corners fall below the middle
BELT_BACK_M = 1.4  # [m] how far behind the scuttle the doors' tops are drawn


def panda(p: XYZ) -> Point3:
    """A vehicle-frame point (forward, left, up) in Panda3D's actor frame (right, forward, up)."""
    return (-p[1], p[0], p[2])


def _hood(mesh: MeshBuilder, c: Cockpit, body: Color) -> None:
    (fx, fz), (rx, rz), w = c.hood_front, c.hood_rear, c.hood_half_width_m
    for side in (-1.0, 1.0):
        corners = [
            panda((rx, 0.0, rz)), panda((fx, 0.0, fz)),
            panda((fx - 0.1, side * 0.9 * w, fz - HOOD_CORNER_DROP_M)),
            panda((rx, side * w, rz - HOOD_CROWN_M)),
        ]  # fmt: skip
        facing(mesh, corners, (0.0, 0.0, 1.0), body)
        lip = [
            panda((fx, 0.0, fz)),
            panda((fx - 0.1, side * 0.9 * w, fz - HOOD_CORNER_DROP_M)),
            panda((fx - 0.1, side * 0.9 * w, fz - 0.25)),
            panda((fx, 0.0, fz - 0.2)),
        ]
        facing(mesh, lip, (0.0, 1.0, 0.0), body)
        scuttle = [  # from the dashboard's front edge up to the bonnet's crowned rear edge
            panda((rx - 0.03, 0.0, c.dash_rear[1])),
            panda((rx - 0.03, side * w, c.dash_rear[1])),
            panda((rx, side * w, rz - HOOD_CROWN_M)),
            panda((rx, 0.0, rz)),
        ]
        facing(mesh, scuttle, (0.0, -1.0, 1.0), SCUTTLE)  # up, towards the driver


def _dashboard(mesh: MeshBuilder, c: Cockpit, head: HeadPosition) -> None:
    (dx, dz), front = c.dash_rear, c.hood_rear[0] - 0.03
    low = dz - 0.45
    mesh.box((0.0, (dx + front) / 2, low), (2 * c.dash_half_width_m, front - dx, dz - low), DASH)
    mesh.box(panda((dx + 0.11, head.y, dz)), (0.34, 0.22, 0.06), DASH)  # instrument binnacle


def _cabin(mesh: MeshBuilder, c: Cockpit) -> None:
    (bx, by, bz), (tx, ty, tz), w = c.pillar_base, c.pillar_top, c.pillar_width_m
    for side in (-1.0, 1.0):
        beam(mesh, panda((bx, side * by, bz)), panda((tx, side * ty, tz)), w, w, TRIM)
        door = panda((bx - BELT_BACK_M / 2, side * (by + w / 2), bz - 0.45))
        mesh.box(door, (w, BELT_BACK_M, 0.45), TRIM)
    beam(mesh, panda((tx, ty, tz)), panda((tx, -ty, tz)), 0.1, w, TRIM)  # header rail
    mesh.box(panda((tx - 0.6, 0.0, tz)), (2 * ty + w, 1.2, 0.03), TRIM)  # roof lining


def cockpit_mesh(c: Cockpit, head: HeadPosition, body: Color) -> MeshBuilder:
    """A car's bonnet (in `body` colour), dashboard, doors, A-pillars and roof."""
    mesh = MeshBuilder("own/cockpit")
    _hood(mesh, c, body)
    _dashboard(mesh, c, head)
    _cabin(mesh, c)
    return mesh


def handlebar_mesh(h: Handlebar, frame: Color) -> MeshBuilder:
    """A stem in the frame's colour and a swept-back bar with grips."""
    mesh = MeshBuilder("own/handlebar")
    (gx, gz), (cx, cz), w = h.grip, h.clamp, h.half_width_m
    beam(mesh, panda((h.head_tube[0], 0.0, h.head_tube[1])), panda((cx, 0.0, cz)), 0.035, 0.035,
         frame)  # fmt: skip
    for side in (-1.0, 1.0):
        bend, inner = (cx - 0.02, side * 0.12, cz), (gx, side * (w - 0.12), gz)
        beam(mesh, panda((cx, 0.0, cz)), panda(bend), 0.025, 0.025, BAR)
        beam(mesh, panda(bend), panda(inner), 0.025, 0.025, BAR)
        beam(mesh, panda(inner), panda((gx - 0.02, side * w, gz)), 0.035, 0.035, GRIP)
    return mesh
