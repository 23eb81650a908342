from __future__ import annotations

import pytest

from carlaverse.fabric.clock import ManualClock, SessionClock


def test_offset_comes_from_the_minimum_rtt_sample() -> None:
    local = ManualClock(100.0)
    clock = SessionClock(local, window=4)
    true_offset = 5000.0
    # (send, one-way out, one-way back): asymmetric slow exchanges bias the estimate
    for out, back in ((0.010, 0.001), (0.0002, 0.0002), (0.004, 0.020)):
        t0 = local.now()
        ts = t0 + out + true_offset
        t1 = local.advance(out + back)
        clock.add_exchange(t0, ts, t1)
        local.advance(0.1)
    assert abs(clock.offset - true_offset) < 1e-9
    assert clock.uncertainty_s == pytest.approx(0.0002)
    assert abs(clock.now() - (local.now() + true_offset)) < 1e-9


def test_window_forgets_old_samples() -> None:
    local = ManualClock()
    clock = SessionClock(local, window=2)
    clock.add_exchange(0.0, 10.0, 0.0)  # perfect, offset 10
    clock.add_exchange(1.0, 21.0, 1.01)  # offset ~19.995
    clock.add_exchange(2.0, 22.0, 2.02)  # pushes the perfect one out
    assert 19.9 < clock.offset < 20.1


def test_negative_rtt_is_ignored() -> None:
    clock = SessionClock(ManualClock())
    clock.add_exchange(1.0, 5.0, 0.5)
    assert not clock.synced
