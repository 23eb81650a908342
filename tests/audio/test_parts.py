"""Unit tests of the renderer's parts: panning gains, the limiter, slots, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.limiter import CEILING, Limiter
from carlaverse.audio.panning import Vbap, layout_azimuths
from carlaverse.audio.propagation import travel_time_s
from carlaverse.audio.renderer import build_renderer
from carlaverse.audio.scene import EmitterSlots


def direction(azimuth_deg: float) -> np.ndarray:
    a = np.radians(azimuth_deg)
    return np.array([[np.cos(a), np.sin(a), 0.0]])


@pytest.mark.parametrize("layout", ["stereo", "quad", "5.1", "ring8", "ring5"])
def test_vbap_gains_have_unit_power_and_point_at_the_source(layout: str) -> None:
    vbap = Vbap(layout_azimuths(layout))
    speakers = layout_azimuths(layout)
    for azimuth in np.arange(-180.0, 180.0, 7.5):
        gains = vbap.gains(direction(azimuth))[0]
        assert np.sum(gains**2) == pytest.approx(1.0)
        assert np.all(gains >= 0.0)
        # On a speaker, only that speaker sounds.
        if azimuth in speakers:
            assert gains[speakers.index(azimuth)] == pytest.approx(1.0)


def test_vbap_energy_vector_points_at_a_source_between_two_speakers() -> None:
    vbap = Vbap(layout_azimuths("quad"))
    gains = vbap.gains(direction(20.0))[0]
    angles = np.radians([45.0, -45.0, 135.0, -135.0])
    vector = np.array([np.sum(gains * np.cos(angles)), np.sum(gains * np.sin(angles))])
    assert np.degrees(np.arctan2(vector[1], vector[0])) == pytest.approx(20.0, abs=0.01)


def test_travel_time_of_a_standing_and_a_moving_source() -> None:
    c = 343.0
    still = travel_time_s(np.array([[100.0, 0.0, 0.0]]), np.zeros((1, 3)), c)
    assert still[0] == pytest.approx(100.0 / c)
    # Approaching along the line of sight at v: the sound left when it was farther.
    v = 30.0
    moving = travel_time_s(np.array([[100.0, 0.0, 0.0]]), np.array([[-v, 0.0, 0.0]]), c)
    assert moving[0] == pytest.approx(100.0 / (c - v))


def test_the_limiter_never_lets_a_sample_over_and_leaves_a_quiet_mix_alone() -> None:
    limiter = Limiter(48_000, 512)
    quiet = np.full((512, 2), 0.5, dtype=np.float32)
    assert np.array_equal(limiter.process(quiet), quiet)
    rng = np.random.default_rng(1)
    for _ in range(50):
        loud = rng.normal(0.0, rng.uniform(0.1, 5.0), (512, 2)).astype(np.float32)
        assert np.max(np.abs(limiter.process(loud))) <= CEILING + 1e-6


def test_slots_fade_out_what_a_scene_drops_and_count_what_does_not_fit() -> None:
    slots = EmitterSlots(2)

    def e(i: str, kind: str = "engine") -> m.AudioEmitter:
        return m.AudioEmitter(i, kind, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 80.0)

    slots.apply([e("a"), e("b"), e("c")], 0.0)
    assert set(slots.ids) == {"a", "b"} and slots.dropped["no free slot"] == 1
    slots.apply([e("a")], 0.05)
    assert slots.state[slots.ids["b"]] == 2  # FADING
    slots.expire(1.0, 0.5)
    assert slots.state[slots.ids["a"]] == 2


def test_the_same_seed_renders_the_same_samples() -> None:
    def render() -> np.ndarray:
        r = build_renderer(AudioConfig(layout="stereo", seed=5))
        emitters = [m.AudioEmitter(f"{k}", k, 10.0, 5.0, 0.0, 3.0, 0.0, 0.0, 90.0, 5.0, 0.5)
                    for k in m.AUDIO_KINDS if k != "siren"]  # fmt: skip
        r.hear(emitters, 0.0)
        return np.concatenate([r.render_block() for _ in range(20)])

    a, b = render(), render()
    assert np.array_equal(a, b) and np.any(a)
