"""Weather timeline interpolation and publishing (on change and at 1 Hz)."""

from __future__ import annotations

import itertools

import pytest

from carlaverse.authority.weather import WeatherPublisher, WeatherTimeline
from carlaverse.traffic.scenario import WeatherKey, WeatherSpec, WeatherValues

SPEC = WeatherSpec(
    initial=WeatherValues(cloudiness=0.0, sun_azimuth_deg=350.0, wind_speed_mps=2.0),
    timeline=[
        WeatherKey(at_s=100.0, cloudiness=1.0, sun_azimuth_deg=10.0),
        WeatherKey(at_s=200.0, precipitation=0.5),
    ],
)


def test_fields_interpolate_between_keyframes_and_carry_over() -> None:
    tl = WeatherTimeline(SPEC)
    assert tl.values_at(0.0)["cloudiness"] == 0.0
    mid = tl.values_at(50.0)
    assert mid["cloudiness"] == pytest.approx(0.5)
    assert mid["sun_azimuth_deg"] == pytest.approx(0.0)  # 350° -> 10° the short way, via 0°
    assert mid["precipitation"] == 0.0 and mid["wind_speed_mps"] == 2.0
    late = tl.values_at(150.0)
    assert late["cloudiness"] == 1.0 and late["precipitation"] == pytest.approx(0.25)
    assert tl.values_at(1e6)["precipitation"] == 0.5  # held after the last keyframe


def test_timeline_loops() -> None:
    tl = WeatherTimeline(WeatherSpec(timeline=SPEC.timeline, loop_s=300.0))
    assert tl.values_at(350.0) == tl.values_at(50.0)


def test_published_on_change_and_at_one_hertz() -> None:
    seq = itertools.count(1)
    still = WeatherPublisher(WeatherSpec(), status_rate_hz=1.0)
    sent = [t for k in range(250) if still.tick(t := k * 0.02, t, lambda: next(seq))]
    assert sent == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0])  # nothing changes: 1 Hz only
    moving = WeatherPublisher(WeatherSpec(timeline=[WeatherKey(at_s=10, cloudiness=1)]), 1.0)
    sent = [t for k in range(500) if moving.tick(t := k * 0.02, t, lambda: next(seq))]
    assert 80 <= len(sent) <= 101  # about every 1 % of cloud cover over 10 s, not every tick
    assert moving.latest is not None and moving.latest.cloudiness == pytest.approx(1.0, abs=0.01)
