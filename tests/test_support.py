"""The small helpers every layer shares (carlaverse/support): one definition each, checked
against values worked by hand."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.support.angles import wrap_angle, wrap_angles, wrap_degrees
from carlaverse.support.ratelog import RateLimitedLog
from carlaverse.support.stats import percentile


def test_percentile_takes_the_sample_nearest_the_quantiles_position() -> None:
    # Five values sorted 1..5 sit at ranks 0..4; the q-quantile sits at rank q·(n − 1) = 4q:
    # the median at rank 2 (value 3), p25 at rank 1 (value 2), p99 at rank 3.96 → 4 (value 5).
    values = [5.0, 1.0, 4.0, 2.0, 3.0]
    assert percentile(values, 0.5) == 3.0
    assert percentile(values, 0.25) == 2.0
    assert percentile(values, 0.99) == 5.0
    assert percentile(values, 0.0) == 1.0 and percentile(values, 1.0) == 5.0
    assert math.isnan(percentile([], 0.5))  # no samples: no figure, not zero


@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=50), st.floats(0, 1))
def test_percentile_is_numpys_nearest_sample(values: list[float], q: float) -> None:
    # numpy's "nearest" method picks the sample at the rounded rank q·(n − 1), as the
    # docstring says ours does; both round a rank exactly half-way to the even one.
    assert percentile(values, q) == float(np.percentile(values, 100 * q, method="nearest"))


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [
        (0.0, 0.0),
        (math.pi / 2, math.pi / 2),  # inside the turn: unchanged
        (-math.pi, -math.pi),  # the interval is closed at −π ...
        (math.pi, -math.pi),  # ... and open at +π: half a turn left is half a turn right
        (3 * math.pi / 2, -math.pi / 2),  # three quarters left = one quarter right
        (-5 * math.pi / 2, -math.pi / 2),  # −450°: a turn and a quarter right
        (7.0, 7.0 - 2 * math.pi),
    ],
)
def test_wrap_angle_maps_onto_minus_pi_to_pi(angle: float, wrapped: float) -> None:
    assert wrap_angle(angle) == pytest.approx(wrapped, abs=1e-12)
    assert float(wrap_angles(np.array([angle]))[0]) == pytest.approx(wrapped, abs=1e-12)


@given(st.floats(-1e4, 1e4))
def test_wrapping_keeps_the_direction(angle: float) -> None:
    w = wrap_angle(angle)
    assert -math.pi <= w < math.pi
    # the same direction: equal sine and cosine (a whole number of turns apart)
    assert math.cos(w) == pytest.approx(math.cos(angle), abs=1e-9)
    assert math.sin(w) == pytest.approx(math.sin(angle), abs=1e-9)


def test_wrap_degrees_maps_bearings_onto_minus_180_to_180() -> None:
    # 350° is 10° short of a turn; 180° is the open end; 540° is a turn and a half.
    assert [wrap_degrees(a) for a in (350.0, 180.0, -180.0, 540.0, 10.0)] == [
        -10.0,
        -180.0,
        -180.0,
        -180.0,
        10.0,
    ]


def test_rate_limited_log_says_each_kind_once_per_interval_and_counts_the_rest(
    caplog: pytest.LogCaptureFixture,
) -> None:
    now = [0.0]
    log = RateLimitedLog(logging.getLogger("test.ratelog"), lambda: now[0], interval_s=1.0)
    with caplog.at_level(logging.WARNING, "test.ratelog"):
        assert log.warning("bad", "bad packet")  # the first is said
        assert not log.warning("bad", "bad packet")  # within 1 s: held back and counted
        assert not log.warning("bad", "bad packet")
        assert log.warning("other", "another kind")  # another kind has its own interval
        now[0] = 1.0  # the interval has passed: said again, with what was held back
        assert log.warning("bad", "bad packet")
    assert [r.getMessage() for r in caplog.records] == [
        "bad packet",
        "another kind",
        "bad packet (2 more like this in the last 1 s)",
    ]
