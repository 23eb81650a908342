"""An articulated walker: torso, head, upper and lower arms and legs, posed from a `Skeleton`.

Joint convention (what a walk node sends in `Skeleton.joints` / `angles`): each joint's
(roll, pitch, yaw) [rad] turns the segment below it about the body's forward (x), left (y) and
up (z) axes, right-handed, applied in that order, starting from the rest pose — limbs hanging
straight down, the head upright. Elbows and knees turn the lower segment relative to the upper
one. So `left_shoulder` roll +π/2 lifts the left arm sideways to horizontal, roll π raises it
overhead; pitch −π/2 on either shoulder points that arm straight ahead. Unknown joints are
ignored, missing ones stay at rest.

Segment lengths are fractions of body height (Drillis & Contini, as the sim camera's walker
uses): the figure is built for 1.75 m and scaled uniformly to the actor's height.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from panda3d.core import NodePath, Quat, Vec3

from carlaverse.render import palette
from carlaverse.render.meshes import Color, MeshBuilder

FIGURE_HEIGHT_M = 1.75  # [m] the figure as built
# Panda3D's actor frame is +x right, +y forward, +z up: the body's axes in it.
FORWARD, LEFT, UP = Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1)


@dataclass(frozen=True, slots=True)
class Limb:
    joint: str  # the upper joint (shoulder, hip)
    lower_joint: str  # elbow, knee
    at: tuple[float, float, float]  # joint position in the Panda actor frame [m]
    upper_m: float  # [m] segment lengths
    lower_m: float
    thickness_m: float
    color: Color


# Heights of a 1.75 m body [m]: hips 0.53 H, shoulders 0.818 H (Drillis & Contini).
HIP_Z, SHOULDER_Z = 0.93, 1.43
LIMBS = (
    Limb("left_shoulder", "left_elbow", (-0.21, 0.0, SHOULDER_Z), 0.32, 0.36, 0.09, palette.SKIN),
    Limb("right_shoulder", "right_elbow", (0.21, 0.0, SHOULDER_Z), 0.32, 0.36, 0.09, palette.SKIN),
    Limb("left_hip", "left_knee", (-0.09, 0.0, HIP_Z), 0.43, 0.50, 0.13, palette.TYRE),
    Limb("right_hip", "right_knee", (0.09, 0.0, HIP_Z), 0.43, 0.50, 0.13, palette.TYRE),
)
JOINTS = ("neck", *(j for limb in LIMBS for j in (limb.joint, limb.lower_joint)))


def joint_quat(roll: float, pitch: float, yaw: float) -> Quat:
    """Roll about forward, then pitch about left, then yaw about up (Panda3D: a * b = a first)."""
    parts = []
    for angle, axis in ((roll, FORWARD), (pitch, LEFT), (yaw, UP)):
        q = Quat()
        q.set_from_axis_angle(math.degrees(angle), axis)
        parts.append(q)
    return parts[0] * parts[1] * parts[2]


def _segment(parent: NodePath, name: str, length: float, thick: float, color: Color) -> NodePath:
    """A pivot at the joint with a box hanging `length` below it."""
    mesh = MeshBuilder(f"figure/{name}")
    mesh.box((0.0, 0.0, -length), (thick, thick, length), color)
    pivot = parent.attach_new_node(name)
    pivot.attach_new_node(mesh.node())
    return pivot


class Figure:
    """One walker's articulated body under `parent`; `pose()` sets its joints."""

    def __init__(self, parent: NodePath, body: Color) -> None:
        self.node = parent.attach_new_node("figure")
        torso = MeshBuilder("figure/torso")
        torso.box((0.0, 0.0, HIP_Z - 0.02), (0.36, 0.2, SHOULDER_Z + 0.05 - HIP_Z), body)
        self.node.attach_new_node(torso.node())
        self.joints: dict[str, NodePath] = {}
        neck = self.node.attach_new_node("neck")
        neck.set_pos(0.0, 0.0, SHOULDER_Z + 0.04)
        head = MeshBuilder("figure/head")
        head.box((0.0, 0.0, 0.04), (0.18, 0.21, FIGURE_HEIGHT_M - SHOULDER_Z - 0.08), palette.SKIN)
        neck.attach_new_node(head.node())
        self.joints["neck"] = neck
        for limb in LIMBS:
            upper = _segment(self.node, limb.joint, limb.upper_m, limb.thickness_m, limb.color)
            upper.set_pos(*limb.at)
            lower = _segment(upper, limb.lower_joint, limb.lower_m, limb.thickness_m, limb.color)
            lower.set_pos(0.0, 0.0, -limb.upper_m)
            self.joints[limb.joint], self.joints[limb.lower_joint] = upper, lower

    def pose(self, angles: Mapping[str, tuple[float, float, float]]) -> None:
        for name, joint in self.joints.items():
            joint.set_quat(joint_quat(*angles.get(name, (0.0, 0.0, 0.0))))

    def place(self, x: float, y: float, z: float, yaw: float, height_m: float) -> None:
        """At a world position, facing `yaw` [rad], scaled uniformly to `height_m`."""
        self.node.set_pos_hpr(x, y, z, math.degrees(yaw) - 90.0, 0.0, 0.0)
        self.node.set_scale(height_m / FIGURE_HEIGHT_M)
