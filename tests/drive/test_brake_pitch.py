"""Brake pitch after a stop: the platform returns to neutral with the washout time constant.

The paper ("Motion Cueing"): washout filters "return the platform axes to their neutral
positions after an acceleration event", at a rate adapted to speed. Once the car stands, the
deceleration is over — a held pedal decelerates nothing — so the brake's nose-down cue must
go home like any other. The documented washout (carlaverse.physics.motion_cueing):
`washout_*_s` is the time to within ~2 % (τ = time/4), and at a standstill the time is
`washout_low_speed_s`. So, counted from the moment the car stops, the pitch decays as
exp(−t/τ), τ = washout_low_speed_s / 4.
"""

from __future__ import annotations

import math

import msgspec
import pytest
from carlaverse_nodes.drive.vehicle_loop import DriveLoop

from tests.drive.support import DT, desktop_loop, keys, run


def test_a_held_brake_at_standstill_washes_out_to_neutral() -> None:
    # On a smooth road: an uneven one tilts the car at rest too, a cue with its own washout.
    base = desktop_loop()
    smooth = msgspec.structs.replace(base.config.road, roughness_class=None)
    loop = DriveLoop(msgspec.structs.replace(base.config, road=smooth), base.vehicle)
    loop.place(0.0, 0.0, 0.0, 10.0)
    loop.engage_drive()
    # A firm stop that keeps the cue inside the platform's clamp (±0.12 rad), so what the
    # platform gets is the washout's own state: pedal 0.4 → 0.4^1.5 = 0.25 of the brake force
    # (the desktop config's curve) → ~3.4 m/s², a_x/a_ref ≈ 0.085 rad plus k_b·0.25.
    braking = keys(0.0, 0.0, 0.4)
    out = loop.step(DT, braking)
    for _ in range(round(8.0 / DT)):  # from 10 m/s at ~3.4 m/s²: stopped after ~3 s
        if out.speed_mps == 0.0:
            break
        out = loop.step(DT, braking)
    assert out.speed_mps == 0.0, "the car did not stop within 8 s"
    at_stop = out.motion.pitch
    assert at_stop < -0.005  # the brake's nose-down cue is there when the wheels stop
    tau = loop.config.motion_cueing.washout_low_speed_s / 4.0  # [s]
    after_tau = run(loop, tau, braking)  # the pedal stays down all the while
    assert after_tau.speed_mps == 0.0
    # One time constant: e^−1 of the value at the stop. 5 %: the loop's 1 ms steps against
    # τ = 0.25 s put the discrete decay within 0.2 % of the continuous one; the rest is room.
    assert after_tau.motion.pitch / at_stop == pytest.approx(math.exp(-1.0), rel=0.05)
    settled = run(loop, 3.0 * tau, braking)  # the documented washout time in all (4 τ)
    assert abs(settled.motion.pitch) <= 0.025 * abs(at_stop)  # e^−4 = 1.8 %: "within ~2 %"
    assert settled.motion.pitch <= 0.0  # home from below, never past neutral
