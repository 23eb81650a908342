"""Golden values for the tyre formulas (paper eq. `pacejka`) and the slip-angle regularisation."""

from __future__ import annotations

import math

import pytest

from carlaverse.physics.tyre import (
    cornering_stiffness,
    friction_ellipse_scale,
    lateral_force,
    self_aligning_torque,
    slip_angle,
)

# (F_z [N], t_p [m], α [rad]) -> M_z [N·m], worked by hand from the paper's formula
# M_z = −F_z·t_p·sin(1.6·atan(8.0·α)); intermediate values quoted to show the working.
GOLDEN_TORQUE = [
    # atan(0.4) = 0.380506377, ×1.6 = 0.608810203, sin = 0.571891840 → −4000·0.03·0.57189
    (4000.0, 0.03, 0.05, -68.627021),
    # odd in α: the same magnitude, opposite sign
    (4000.0, 0.03, -0.05, 68.627021),
    # atan(0.8) = 0.674740942, ×1.6 = 1.079585508, sin = 0.881762369
    (6500.0, 0.035, 0.1, -200.600939),
    # atan(1.6) = 1.012197011, ×1.6 = 1.619515218, sin = 0.998813470 (near the peak)
    (3000.0, 0.02, 0.2, -59.928808),
    # atan(8) = 1.446441332, ×1.6 = 2.314306132, sin = 0.736097396 (past the peak: falls off)
    (5000.0, 0.04, 1.0, -147.219479),
    # small angle: atan(0.08) = 0.079829986, ×1.6 = 0.127727977, sin = 0.127380959
    (7800.0, 0.035, 0.01, -34.775002),
    (5000.0, 0.04, 0.0, 0.0),
]


@pytest.mark.parametrize(("f_z", "t_p", "alpha", "expected"), GOLDEN_TORQUE)
def test_self_aligning_torque_matches_hand_computed_values(
    f_z: float, t_p: float, alpha: float, expected: float
) -> None:
    # 1e-6 N·m: the hand values are quoted to 6 decimals; the formula is evaluated exactly.
    assert self_aligning_torque(f_z, t_p, alpha) == pytest.approx(expected, abs=1e-6)


def test_aligning_torque_opposes_the_slip_and_scales_with_load_and_trail() -> None:
    base = self_aligning_torque(4000.0, 0.03, 0.05)
    assert base < 0.0
    assert self_aligning_torque(8000.0, 0.03, 0.05) == pytest.approx(2.0 * base)
    assert self_aligning_torque(4000.0, 0.06, 0.05) == pytest.approx(2.0 * base)


def test_slip_angle_is_finite_and_zero_at_standstill() -> None:
    assert slip_angle(0.0, 0.0, 1.0) == 0.0
    # Sliding sideways at standstill: the regularised angle is finite and opposes v_lat.
    assert slip_angle(0.0, 2.0, 1.0) == pytest.approx(-math.atan(2.0))
    # Above v_min it is the textbook angle.
    assert slip_angle(20.0, -1.0, 1.0) == pytest.approx(math.atan(1.0 / 20.0))


def test_lateral_force_linear_range_and_friction_limit() -> None:
    f_z, mu, b, c = 4000.0, 1.0, 11.0, 1.3
    small = 1e-4
    # Cornering stiffness B·C·D is the slope at α = 0 (to 1e-6 relative at α = 1e-4 rad).
    slope = lateral_force(small, f_z, mu, b, c) / small
    assert slope == pytest.approx(cornering_stiffness(f_z, mu, b, c), rel=1e-6)
    peak = max(lateral_force(a / 1000.0, f_z, mu, b, c) for a in range(0, 600))
    assert peak == pytest.approx(mu * f_z, rel=1e-4)


def test_friction_ellipse() -> None:
    assert friction_ellipse_scale(0.0, 4000.0, 1.0) == 1.0
    assert friction_ellipse_scale(4000.0 * 0.6, 4000.0, 1.0) == pytest.approx(0.8)
    assert friction_ellipse_scale(5000.0, 4000.0, 1.0) == 0.0
