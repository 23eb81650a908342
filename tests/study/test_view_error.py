"""View error against the truth: figures worked by hand, quantiles held to numpy's."""

from __future__ import annotations

import numpy as np

from carlaverse.study.view_error import ViewSample, position_at, summarise, view_errors


def test_position_between_samples_is_linear() -> None:
    track = [(0.0, 0.0, 0.0), (1.0, 10.0, 0.0), (2.0, 10.0, 10.0)]
    assert position_at(track, 0.25) == (2.5, 0.0)
    assert position_at(track, 1.5) == (10.0, 5.0)
    assert position_at(track, 1.0) == (10.0, 0.0)
    assert position_at(track, -0.1) is None and position_at(track, 2.1) is None


def test_a_view_150_ms_behind_a_10_mps_actor_is_1_5_m_off() -> None:
    # P02 drives along x at 10 m/s, a pose every 20 ms; P01's view shows it where it was
    # 150 ms earlier: 10 m/s x 0.15 s = 1.5 m behind, at every sample.
    truth = {"P02": [(t / 50, 10.0 * t / 50, 3.0) for t in range(0, 251)]}
    samples = [ViewSample(t, "P02", 10.0 * (t - 0.15), 3.0) for t in np.arange(1.0, 4.0, 0.1)]
    samples.append(ViewSample(99.0, "P02", 0.0, 0.0))  # after the track: no truth, not counted
    (figures,) = view_errors(samples, truth).values()
    assert figures.samples == 30
    assert abs(figures.p50_m - 1.5) < 1e-9 and abs(figures.max_m - 1.5) < 1e-9


def test_quantiles_are_numpys_linear() -> None:
    values = [0.3, 2.0, 0.1, 5.5, 1.2, 0.7, 0.9]
    figures = summarise(values)
    assert abs(figures.p50_m - np.percentile(values, 50)) < 1e-12
    assert abs(figures.p95_m - np.percentile(values, 95)) < 1e-12
    assert figures.max_m == 5.5
