"""The session clock: minimum-RTT estimate, skew, and a disciplined offset that never steps back.

Everything runs on a ManualClock: the "authority" is a function of local time, exchanges are
made by hand, and the publisher is a loop reading `SessionClock.now()` the way NodeClient's
pose thread stamps `pose.t`.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse.transport.clock import MAX_SLEW, ManualClock, SessionClock

RTT_S = 0.001  # [s] a symmetric LAN exchange


def exchange(clock: SessionClock, local: ManualClock, offset: float, out: float, back: float):
    t0 = local.now()
    ts = t0 + out + offset
    t1 = local.advance(out + back)
    clock.add_exchange(t0, ts, t1)


def test_estimate_comes_from_the_minimum_rtt_sample() -> None:
    local = ManualClock(100.0)
    clock = SessionClock(local, window=4)
    true_offset = 5000.0
    # (one-way out, one-way back): asymmetric slow exchanges bias the estimate
    for out, back in ((0.010, 0.001), (0.0002, 0.0002), (0.004, 0.020)):
        exchange(clock, local, true_offset, out, back)
        local.advance(0.1)
    assert abs(clock.target(local.now()) - true_offset) < 1e-9
    assert clock.uncertainty_s == pytest.approx(0.0002)
    local.advance(1.0)  # the first (worse) sample was stepped to; the better one is slewed in
    assert abs(clock.now() - (local.now() + true_offset)) < 1e-9


def test_window_forgets_old_samples() -> None:
    local = ManualClock()
    clock = SessionClock(local, window=2)
    clock.add_exchange(0.0, 10.0, 0.0)  # perfect, offset 10
    clock.add_exchange(1.0, 21.0, 1.01)  # offset ~19.995
    clock.add_exchange(2.0, 22.0, 2.02)  # pushes the perfect one out
    assert 19.9 < clock.target(2.0) < 20.1


def test_negative_rtt_is_ignored() -> None:
    clock = SessionClock(ManualClock())
    clock.add_exchange(1.0, 5.0, 0.5)
    assert not clock.synced


def run_publisher(
    true_offset: Callable[[float], float], seconds: float, clock: SessionClock, local: ManualClock
) -> tuple[list[float], ...]:
    """Publish at 50 Hz for `seconds`, syncing 3 exchanges every 2 s as NodeClient does.

    Returns the published times and the offsets applied at each of them.
    """
    published, offsets = [], []
    local_times, skews = [], []
    next_sync = local.now()
    end = local.now() + seconds
    while local.now() < end:
        if local.now() >= next_sync:
            for _ in range(3):
                exchange(clock, local, true_offset(local.now()), RTT_S / 2, RTT_S / 2)
            next_sync = local.now() + 2.0
        published.append(clock.now())
        offsets.append(published[-1] - local.now())
        local_times.append(local.now())
        skews.append(abs(clock.skew))
        local.advance(0.02)
    return published, offsets, local_times, skews


@pytest.mark.parametrize("change_s", [-0.00075, +0.020])
def test_an_offset_change_is_slewed_pose_t_strictly_increasing(
    change_s: float, caplog: pytest.LogCaptureFixture
) -> None:
    local = ManualClock(50.0)
    clock = SessionClock(local)
    base = 1.7e9

    def true_offset(t: float) -> float:  # the authority's timeline moves at local t = 100 s
        return base + (change_s if t >= 100.0 else 0.0)

    with caplog.at_level(logging.INFO, logger="carlaverse.transport.clock"):
        published, offsets, local_times, skews = run_publisher(true_offset, 60.0, clock, local)
    assert all(b > a for a, b in itertools.pairwise(published))
    # beyond the skew it follows, the offset changes at most MAX_SLEW (to float resolution)
    slews = [
        abs(offsets[i + 1] - offsets[i]) / (local_times[i + 1] - local_times[i])
        - max(skews[i], skews[i + 1])
        for i in range(len(offsets) - 1)
    ]
    assert max(slews[1:]) <= MAX_SLEW + 2e-5
    slew_time = abs(change_s) / MAX_SLEW
    assert max(slews) >= 0.9 * MAX_SLEW  # ... and at full rate while correcting
    assert clock.steps == 1  # only the first sync stepped
    assert sum("stepped" in r.message for r in caplog.records) == 1
    settled = [o for o, t in zip(offsets, published, strict=False) if t - base > 102 + slew_time]
    # A change larger than the RTT bound is seen as a new timeline: older evidence is dropped
    # and the estimate is exact. One within it is indistinguishable from path noise and leans
    # the skew fit for a while; the error stays a fraction of the RTT/2 uncertainty.
    tolerance = 1e-6 if abs(change_s) > RTT_S else RTT_S / 4
    assert settled and all(abs(o - true_offset(110.0)) < tolerance for o in settled)


def test_a_large_forward_error_is_stepped_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    local = ManualClock()
    clock = SessionClock(local)
    exchange(clock, local, 100.0, 0.0005, 0.0005)
    local.advance(1.0)
    with caplog.at_level(logging.WARNING, logger="carlaverse.transport.clock"):
        exchange(clock, local, 101.0, 0.0005, 0.0005)
    assert clock.steps == 2 and clock.now() - local.now() == pytest.approx(101.0)
    assert "stepped by +1.000000 s" in caplog.text


def test_a_large_backward_error_is_slewed_not_stepped() -> None:
    local = ManualClock()
    clock = SessionClock(local)
    exchange(clock, local, 100.0, 0.0005, 0.0005)
    before = clock.now()
    exchange(clock, local, 99.0, 0.0005, 0.0005)
    assert clock.steps == 1 and clock.now() > before


def test_a_new_authority_timeline_may_step_back() -> None:
    local = ManualClock()
    clock = SessionClock(local)
    exchange(clock, local, 100.0, 0.0005, 0.0005)
    clock.reset()
    exchange(clock, local, 50.0, 0.0005, 0.0005)
    assert clock.steps == 2 and clock.now() - local.now() == pytest.approx(50.0)


def test_skew_is_estimated_and_followed() -> None:
    local = ManualClock()
    clock = SessionClock(local)
    skew = 200e-6  # the authority's oscillator runs 200 ppm fast

    def true_offset(t: float) -> float:
        return 1000.0 + skew * t

    run_publisher(true_offset, 60.0, clock, local)
    assert clock.skew == pytest.approx(skew, abs=5e-6)
    for _ in range(100):  # between syncs the skew keeps the offset on track
        local.advance(0.019)
        assert abs(clock.now() - (local.now() + true_offset(local.now()))) < 50e-6


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(0.0001, 5.0),  # local time advanced before the exchange [s]
            st.floats(-2.0, 2.0),  # authority offset change [s]
            st.floats(0.0, 0.2),  # one-way out [s]
            st.floats(0.0, 0.2),  # one-way back [s]
            st.booleans(),  # read now() before the exchange
        ),
        max_size=40,
    )
)
def test_now_is_monotonic_under_random_exchanges(steps: list) -> None:  # type: ignore[type-arg]
    local = ManualClock(10.0)
    clock = SessionClock(local)
    offset = 0.0
    exchange(clock, local, offset, 0.001, 0.001)  # the first sync may step either way
    last = clock.now()
    for advance, change, out, back, read in steps:
        local.advance(advance)
        if read:
            assert clock.now() > last
            last = clock.now()
        offset += change
        exchange(clock, local, offset, out, back)
        assert clock.now() >= last
        last = clock.now()
        local.advance(1e-6)
        assert clock.now() > last
        last = clock.now()


def test_a_stamp_taken_on_the_local_clock_reads_as_session_time_later() -> None:
    # A pose callback stamps its arrival with `local.now()` and the world view turns it into
    # session time when it drains, ms later. Whatever happened meanwhile (here an exchange
    # that moved the estimate by 3 ms, slewed in at most 1 %), the stamp reads as the session
    # time it was taken at: before the exchange the offset was 5000 s flat, so 5000 s on.
    local = ManualClock(100.0)
    clock = SessionClock(local)
    exchange(clock, local, 5000.0, RTT_S / 2, RTT_S / 2)
    local.advance(1.0)
    stamp, then = local.now(), clock.now()
    assert clock.at(stamp) == then == stamp + 5000.0
    local.advance(0.010)
    exchange(clock, local, 5000.003, RTT_S / 2, RTT_S / 2)  # later, and a better estimate
    assert clock.at(stamp) == pytest.approx(stamp + 5000.0, abs=1e-12)
    assert clock.at(local.now()) == pytest.approx(clock.now(), abs=1e-12)
