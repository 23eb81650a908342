"""The quarter-car of the vertical model against the 2-DOF system solved by eigenvalues."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from carlaverse.physics.params import Suspension
from carlaverse.physics.vertical import QuarterCar

GOLDEN = Suspension()  # the IRI's Golden Car (Sayers 1995)


def body_bounce_mode(s: Suspension) -> complex:
    """The body-bounce eigenvalue of  m_s·z̈_s = k(z_u − z_s) + c(ż_u − ż_s),
    m_u·z̈_u = −k_t·z_u − k(z_u − z_s) − c(ż_u − ż_s)  (per kg of m_s, road at rest),
    from the state matrix: the pair with the smaller imaginary part."""
    k, c, kt, mu = s.spring_per_kg, s.damping_per_kg, s.tyre_per_kg, s.unsprung_ratio
    a = np.array(
        [
            [0, 1, 0, 0],
            [-k, -c, k, c],
            [0, 0, 0, 1],
            [k / mu, c / mu, -(k + kt) / mu, -c / mu],
        ]
    )  # state (z_s, ż_s, z_u, ż_u)
    modes = [e for e in np.linalg.eigvals(a) if e.imag > 0]
    return min(modes, key=lambda e: e.imag)


def test_the_body_bounces_at_the_golden_cars_frequency_and_decays_at_its_rate() -> None:
    mode = body_bounce_mode(GOLDEN)  # ≈ −2.6 ± 7.3j: 1.17 Hz, ζ ≈ 0.33
    car, dt = QuarterCar(GOLDEN), 0.001
    car.z_s = 0.05  # the body lifted 5 cm and let go over a flat road
    body = []
    for _ in range(4000):
        car.step(dt, 0.0)
        body.append(car.z_s)
    # Upward zero crossings give the damped period; successive peaks the decay.
    ups = [i for i in range(1, len(body)) if body[i - 1] < 0.0 <= body[i]]
    period = (ups[-1] - ups[0]) * dt / (len(ups) - 1)
    assert 2 * math.pi / period == pytest.approx(mode.imag, rel=0.02)
    peaks = [max(body[a:b]) for a, b in itertools.pairwise(ups)]
    decay = math.log(peaks[0] / peaks[1]) / period
    # 5 %: the wheel-hop mode (11 Hz) rides on the first peak a little.
    assert decay == pytest.approx(-mode.real, rel=0.05)


def test_a_road_raised_and_held_lifts_the_body_by_as_much() -> None:
    car = QuarterCar(GOLDEN)
    for _ in range(10000):  # 10 s: the body mode decays as e^(−2.6 t)
        car.step(0.001, 0.1)
    assert car.z_s == pytest.approx(0.1, abs=1e-6)  # springs carry no static offset
    assert car.z_u == pytest.approx(0.1, abs=1e-6)
