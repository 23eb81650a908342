"""Tyre models: slip angle, lateral force and self-aligning torque.

Sign convention (body frame x forward, y left, z up; angles counter-clockwise positive): a
positive slip angle α produces a positive (leftward) lateral force, and the self-aligning
torque opposes it — it turns the wheel back toward the direction of travel.

Slip angles are singular at standstill (α = atan(v_lat / v_long) with v_long → 0). We
regularise the denominator with a minimum speed: below it the tyre acts as a stiff lateral
damper (F ∝ −v_lat), which stops a sliding car without chatter, and a steered wheel at
standstill produces no force, so the car cannot turn on the spot. At low forward speed the
regularised slip reproduces the kinematic (no-slip) yaw rate r = v·tan δ / L.
"""

from __future__ import annotations

import math


def slip_angle(v_long: float, v_lat: float, v_min: float) -> float:
    """Slip angle [rad] of a wheel from its velocity in the wheel frame [m/s].

    `v_min` [m/s] regularises the denominator so α stays finite and smooth through v = 0.
    """
    denominator = abs(v_long)
    if denominator < v_min:
        denominator = v_min
    return -math.atan(v_lat / denominator)


def lateral_force(alpha: float, f_z: float, mu: float, b: float, c: float) -> float:
    """Lateral force [N] from a simplified Pacejka magic formula D·sin(C·atan(B·α)).

    D = μ·F_z is the friction limit; B [1/rad] sets the cornering stiffness (B·C·D at α = 0);
    C ≈ 1.3 shapes the fall-off after the peak.
    """
    return mu * f_z * math.sin(c * math.atan(b * alpha))


def cornering_stiffness(f_z: float, mu: float, b: float, c: float) -> float:
    """Slope dF_y/dα at α = 0 [N/rad] of `lateral_force` — the linear-range stiffness."""
    return b * c * mu * f_z


def self_aligning_torque(f_z: float, t_p: float, alpha: float) -> float:
    """Self-aligning torque [N·m] at the contact patch (paper eq. `eq:pacejka`).

    M_z = −F_z · t_p · sin(1.6 · atan(8.0 · α)), with vertical load F_z [N], pneumatic trail
    t_p [m] and slip angle α [rad]. The constants 1.6 and 8.0 are the paper's.
    """
    return -f_z * t_p * math.sin(1.6 * math.atan(8.0 * alpha))


def friction_ellipse_scale(f_x: float, f_z: float, mu: float) -> float:
    """Fraction of lateral grip left when the tyre also transmits a longitudinal force F_x [N].

    sqrt(1 − (F_x/μF_z)²): the friction circle, so hard braking in a bend costs lateral grip.
    """
    limit = mu * f_z
    if limit <= 0.0:
        return 0.0
    used = f_x / limit
    used *= used
    return math.sqrt(1.0 - used) if used < 1.0 else 0.0
