"""Collision impulses on a planar rigid body.

The authority decides the impulse J (world frame, N·s) and the contact point; the node only
applies it: Δv = J/m at the centre of gravity and Δω_z = (r × J)_z / I_z, r from the CG to
the contact point. Vertical components are left to the motion cue (the chassis is planar).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.physics.single_track import ChassisState


@dataclass(frozen=True, slots=True)
class ImpulseResponse:
    """What one impulse did to the body, for haptics and motion cues."""

    dvx_body: float  # [m/s] forward velocity change
    dvy_body: float  # [m/s] leftward velocity change
    dyaw_rate: float  # [rad/s]
    dvz: float  # [m/s] vertical component J_z/m (not applied to the planar chassis)

    def magnitude(self) -> float:
        """|Δv| [m/s] including the vertical part."""
        return math.sqrt(self.dvx_body**2 + self.dvy_body**2 + self.dvz**2)


def apply_impulse(
    state: ChassisState,
    impulse_ns: tuple[float, float, float],
    point_m: tuple[float, float, float],
    mass_kg: float,
    yaw_inertia_kgm2: float,
) -> ImpulseResponse:
    """Change `state` by the impulse J applied at `point_m` (both world frame)."""
    jx, jy, jz = impulse_ns
    rx, ry = point_m[0] - state.x, point_m[1] - state.y
    c, s = math.cos(state.yaw), math.sin(state.yaw)
    response = ImpulseResponse(
        dvx_body=(jx * c + jy * s) / mass_kg,
        dvy_body=(-jx * s + jy * c) / mass_kg,
        dyaw_rate=(rx * jy - ry * jx) / yaw_inertia_kgm2,
        dvz=jz / mass_kg,
    )
    state.vx += response.dvx_body
    state.vy += response.dvy_body
    state.yaw_rate += response.dyaw_rate
    return response
