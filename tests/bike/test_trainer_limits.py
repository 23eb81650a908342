"""What the trainer renders of the ride, and what it reports it cannot.

Expected values come from the road's physics written out here (paper, "Propulsion and
Resistance"): F_res = f_R·m·g·cos θ + m·g·sin θ + ½·ρ·c_W·A·v², θ = atan(grade), and
m·dv/dt = P/v − F_res for the rider on the road. The trainer is the simulated FTMS trainer
(its flywheel and brake, `FlywheelParams`), driven through its FTMS bytes on a manual clock by
the real bike loop body with the shipped calibrated table, as the loop process drives it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop, BikeOutput
from carlaverse_nodes.bike.config import BikeNodeConfig, RoadSettings, resolve_table
from carlaverse_nodes.bike.hmi_bridge import trainer_notice
from carlaverse_nodes.bike.trainer_command import TrainerFeelParams, TrainerLimit

from carlaverse.cli.calibrate import ManualClock
from carlaverse.hal import open_trainer
from carlaverse.hal.trainer.ftms_sim import FlywheelParams, SimFtmsTrainer, brake_force

G = 9.81  # [m/s²]
M = 90.0  # [kg] bike and rider (BicycleParams' default)
ROLLING_N = 0.004 * M * G  # f_R·m·g on the flat [N]
DRAG = 0.5 * 1.2 * 0.9 * 0.5  # ½·ρ·c_W·A [kg/m]
DT = 0.005  # [s] the loop's tick
WRITE_EVERY = 50  # ticks: the loop's 4 Hz trainer writes at 200 Hz
FLYWHEEL = FlywheelParams()


def road_force(speed: float, grade_percent: float) -> float:
    theta = math.atan(grade_percent / 100)
    return ROLLING_N * math.cos(theta) + M * G * math.sin(theta) + DRAG * speed**2


def steady(grade_percent: float, speed: float) -> BikeOutput:
    config = BikeNodeConfig(road=RoadSettings(grade_percent=grade_percent))
    loop = BikeLoop(config, resolve_table(config))
    for _ in range(100):
        out = loop.step(DT, speed, 0.0, 0.0)
    return out


def test_a_ten_percent_climb_at_3_mps_is_beyond_the_brake() -> None:
    out = steady(10.0, 3.0)
    wanted = road_force(3.0, 10.0)  # 87.8 N of slope + 3.5 rolling + 2.4 air = 93.8 N
    assert out.resistance_n == pytest.approx(wanted, rel=1e-9)
    most = brake_force(FLYWHEEL, 3.0, 100.0)  # the brake at 100 %: 66.7 N
    assert out.trainer_limit is TrainerLimit.TOO_STEEP and out.resistance_percent == 100.0
    # the table measured 100 % to ±0.5 N (FTMS power in whole watts)
    assert out.trainer_missing_n == pytest.approx(wanted - most, abs=0.5)
    assert trainer_notice(out.trainer_limit, out.trainer_missing_n).startswith("trainer at 100 %")


def test_a_descent_would_push_the_bike_and_a_brake_cannot() -> None:
    out = steady(-6.0, 5.0)
    assert road_force(5.0, -6.0) < 0  # −52.8 N of slope against 10.3 N of rolling and air
    assert out.trainer_limit is TrainerLimit.CANNOT_PUSH and out.resistance_percent == 0.0


def test_on_the_flat_the_trainer_renders_the_road() -> None:
    out = steady(0.0, 5.0)
    assert out.trainer_limit is TrainerLimit.NONE and out.trainer_missing_n == 0.0
    # the level whose brake force is the road's (the table's ±1 % in force terms)
    rendered = brake_force(FLYWHEEL, 5.0, out.resistance_percent)
    assert rendered == pytest.approx(road_force(5.0, 0.0), abs=0.01 * FLYWHEEL.brake_max_n)


Script = Callable[[ManualClock, SimFtmsTrainer, BikeLoop], float]


def ride(power_w: float, inertia: bool, script: Script) -> tuple[float, dict]:
    clock = ManualClock()
    trainer = open_trainer({"backend": "ftms_sim", "options": {
        "rider_power_w": power_w, "power_sigma_w": 0.0}}, clock=clock)  # fmt: skip
    assert isinstance(trainer, SimFtmsTrainer)
    config = BikeNodeConfig(trainer_feel=TrainerFeelParams(inertia=inertia))
    loop = BikeLoop(config, resolve_table(config))
    seconds = script(clock, trainer, loop)
    return seconds, loop.trainer.summary()


def tick(clock: ManualClock, trainer: SimFtmsTrainer, loop: BikeLoop) -> BikeOutput:
    """One loop tick as the loop process runs it: read, step, write the level at 4 Hz."""
    clock.advance(DT)
    out = loop.step(DT, trainer.read().speed_mps or 0.0, 0.0, 0.0)
    if round(clock.t / DT) % WRITE_EVERY == 0:
        trainer.set_resistance(out.resistance_percent)
    return out


def time_between(low: float, high: float) -> Script:
    """Seconds the wheel takes from `low` to `high` m/s, pedalling from rest."""

    def script(clock: ManualClock, trainer: SimFtmsTrainer, loop: BikeLoop) -> float:
        start = None
        while clock.t < 60:
            speed = tick(clock, trainer, loop).speed_mps
            start = clock.t if start is None and speed >= low else start
            if speed >= high:
                return clock.t - (start or 0.0)
        raise AssertionError(f"never reached {high} m/s")

    return script


def road_time(power_w: float, low: float, high: float) -> float:
    """m·dv/dt = P/v − F_res on the flat, integrated in 0.1 ms steps."""
    speed, t, h = low, 0.0, 1e-4
    while speed < high:
        speed += (power_w / speed - road_force(speed, 0.0)) / M * h
        t += h
    return t


def test_speeding_up_the_rider_feels_the_whole_mass() -> None:
    """At 250 W from 5.5 to 7.5 m/s a 90 kg bike takes 8.0 s; the bare 12 kg flywheel ~1 s.
    The brake adds the missing 78 kg from the wheel's smoothed acceleration, which lags the
    true one (τ = 1.5 s, for stability) while the acceleration falls: so a little slower."""
    road = road_time(250.0, 5.5, 7.5)
    felt, _ = ride(250.0, True, time_between(5.5, 7.5))
    bare, _ = ride(250.0, False, time_between(5.5, 7.5))
    assert bare < 0.25 * road  # what the rider got before
    assert 0.9 * road <= felt <= 1.3 * road, (felt, road)


def coast_from(high: float, low: float) -> Script:
    """Seconds from `high` to `low` m/s without pedalling: a rig spins the roller up to
    `high`, lets the loop settle on it for 2 s, and lets go."""

    def script(clock: ManualClock, trainer: SimFtmsTrainer, loop: BikeLoop) -> float:
        trainer.drive(high, 0.0)
        for _ in range(round(2.0 / DT)):
            tick(clock, trainer, loop)
        trainer.release()
        start = clock.t
        while clock.t < start + 60:
            if tick(clock, trainer, loop).speed_mps <= low:
                return clock.t - start
        raise AssertionError(f"never slowed to {low} m/s")

    return script


def coast_time(mass_kg: float, constant_n: float, quadratic: float, high: float,
               low: float) -> float:  # fmt: skip
    """m·dv/dt = −(a + b·v²): t = m/√(ab)·[atan(v·√(b/a))] from low to high."""
    k = math.sqrt(quadratic / constant_n)
    return mass_kg / math.sqrt(constant_n * quadratic) * (math.atan(high * k) - math.atan(low * k))


def test_coasting_lasts_as_long_as_the_flywheel_allows_and_the_rest_is_reported() -> None:
    road = coast_time(M, ROLLING_N, DRAG, 10.0, 5.0)  # 25.7 s
    # A brake rendering the road's force on the 12 kg flywheel: m_eq/m of the road's time.
    rendered_road = FLYWHEEL.mass_eq_kg / M * road  # 3.4 s
    # The most a brake can do while slowing is to let go: the flywheel's own drag remains.
    floor = coast_time(FLYWHEEL.mass_eq_kg, FLYWHEEL.friction_n, FLYWHEEL.fan_n_per_mps2,
                       10.0, 5.0)  # 6.1 s  # fmt: skip
    bare, _ = ride(0.0, False, coast_from(10.0, 5.0))
    assert bare == pytest.approx(rendered_road, rel=0.1)  # what the rider got before
    felt, summary = ride(0.0, True, coast_from(10.0, 5.0))
    # The level written before the rig let go holds up to one 4 Hz write, and the smoothed
    # acceleration takes its τ to tell: a few tenths of a second of extra braking.
    assert felt == pytest.approx(floor, rel=0.1)
    assert felt < 0.3 * road  # the rest the trainer cannot render; it says so:
    assert summary["too_light_s"] >= 0.8 * felt
    assert summary["flywheel_mass_eq_kg"] == pytest.approx(FLYWHEEL.mass_eq_kg, rel=0.02)


def test_a_table_without_the_measured_range_judges_nothing_and_says_so() -> None:
    config = BikeNodeConfig(road=RoadSettings(grade_percent=10.0))
    table = resolve_table(config)
    by_hand = type(table)(table.speeds_mps, table.forces_n, table.resistance_percent)
    loop = BikeLoop(config, by_hand)
    out = loop.step(DT, 3.0, 0.0, 0.0)
    assert out.trainer_limit is TrainerLimit.NONE and out.resistance_percent == 100.0
    summary = loop.trainer.summary()
    assert summary["range_known"] is False and summary["inertia_added_kg"] == 0.0
