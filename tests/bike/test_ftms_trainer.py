"""The FTMS client on the simulated FTMS trainer: control, resistance, reconnect, calibration."""

from __future__ import annotations

import math

import pytest

from carlaverse.cli import main
from carlaverse.cli.calibrate import ManualClock
from carlaverse.hal import open_trainer
from carlaverse.hal.trainer import ftms_codec as codec
from carlaverse.hal.trainer.ftms_sim import FlywheelParams, SimFtmsTrainer, brake_force
from carlaverse.hal.trainer.resistance_table import ResistanceTable, load_table


def sim_trainer(**options: object) -> tuple[SimFtmsTrainer, ManualClock]:
    clock = ManualClock()
    trainer = open_trainer({"backend": "ftms_sim", "options": options}, clock=clock)
    assert isinstance(trainer, SimFtmsTrainer)
    return trainer, clock


def ride(trainer: SimFtmsTrainer, clock: ManualClock, seconds: float) -> None:
    for _ in range(round(seconds / 0.05)):
        clock.advance(0.05)
        trainer.read()


def test_takes_control_and_more_resistance_slows_the_rider() -> None:
    trainer, clock = sim_trainer(power_sigma_w=0.0, rider_power_w=200.0)
    assert trainer.in_control and trainer.connected  # request control answered 0x80 00 01
    ride(trainer, clock, 30.0)
    free = trainer.read()
    assert free.power_w == pytest.approx(200, abs=1)
    # 200 W at r = 0: 2v + 0.15v³ = 200 → v ≈ 10.6 m/s (38 km/h)
    assert free.speed_mps == pytest.approx(10.6, abs=0.1)
    assert free.cadence_rpm == pytest.approx(free.speed_mps / 7.0 * 60, abs=0.5)
    trainer.set_resistance(60.0)
    assert trainer.peripheral.resistance_percent == pytest.approx(60.0)
    ride(trainer, clock, 30.0)
    slowed = trainer.read()
    assert slowed.speed_mps < 0.6 * free.speed_mps
    force = brake_force(trainer.options.flywheel, slowed.speed_mps, 60.0)  # steady: P = F·v
    assert force * slowed.speed_mps == pytest.approx(200, rel=0.02)
    assert trainer.counters["bike_data"] >= 200 and not trainer.counters["bad_bike_data"]


def test_refused_without_control_and_malformed_bytes_are_counted() -> None:
    trainer, _ = sim_trainer()
    trainer.peripheral.controlled = False
    trainer.link.write_control(codec.set_target_resistance(10))
    assert trainer.responses[-1].result == codec.ResultCode.CONTROL_NOT_PERMITTED
    trainer.link.write_control(b"\x42")
    assert trainer.responses[-1] == codec.Response(0x42, codec.ResultCode.NOT_SUPPORTED)
    trainer.on_bike_data(b"\x44\x00\x01")
    trainer.on_response(b"\x10")
    assert trainer.counters["bad_bike_data"] == 1 and trainer.counters["bad_response"] == 1
    assert trainer.counters["refused"] == 2


def test_after_a_link_loss_it_takes_control_again_and_restores_resistance() -> None:
    trainer, clock = sim_trainer()
    trainer.set_resistance(35.0)
    trainer.sim_link.unplug()
    assert not trainer.connected and not trainer.in_control
    trainer.peripheral.resistance_percent = 0.0  # the trainer forgot (it power-cycled)
    trainer.set_resistance(35.2)  # commanded while down: remembered, not sent
    seen = trainer.counters["bike_data"]
    ride(trainer, clock, 2.0)
    assert trainer.counters["bike_data"] == seen  # no notifications while unplugged
    trainer.sim_link.plug()
    assert trainer.in_control and trainer.counters["connects"] == 2
    assert trainer.peripheral.resistance_percent == pytest.approx(35.2)
    ride(trainer, clock, 1.0)
    assert trainer.counters["bike_data"] > seen


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> ResistanceTable:
    """`carlaverse calibrate trainer` against the simulated trainer, 15 s ramps."""
    out = tmp_path_factory.mktemp("calibrate") / "table.yaml"
    assert main(["calibrate", "trainer", "--out", str(out), "--ramp-s", "15"]) == 0
    return load_table(out)


def test_calibrate_trainer_writes_a_table_that_inverts_the_brake(
    calibrated: ResistanceTable,
) -> None:
    table = calibrated
    assert table.trainer == "ftms_sim" and len(table.speeds_mps) == 16
    flywheel = FlywheelParams()  # the simulated trainer's own physics: the truth measured
    # The table must answer with the level whose brake force is the one asked for.
    for speed, level in [(3.0, 25.0), (6.0, 50.0), (8.0, 70.0), (10.0, 40.0), (3.0, 95.0)]:
        force = brake_force(flywheel, speed, level)
        assert table.percent(speed, force) == pytest.approx(level, abs=1.0), (speed, level)
    assert table.percent(5.0, 1.0) == 0.0  # less than the bare friction: no brake at all


@pytest.mark.parametrize("speed", [1.0, 1.5, 2.0])
def test_the_table_holds_at_walking_speed(calibrated: ResistanceTable, speed: float) -> None:
    """The slowest rows are measured too. FTMS reports power in whole watts: at 1 m/s each
    force sample F = P/v carries ±0.5 N, against a brake span of F_max·(1 − e^(−1/4)) = 26.5 N
    per 100 %, so ±1.9 %; 2.5 % leaves room for the samples' interpolation."""
    flywheel = FlywheelParams()
    for level in range(0, 101, 10):
        force = brake_force(flywheel, speed, level)
        assert calibrated.percent(speed, force) == pytest.approx(level, abs=2.5), (speed, level)


def test_calibration_measures_what_the_trainer_can_render(calibrated: ResistanceTable) -> None:
    """Its force at 0 % and at 100 % per speed, and its flywheel's inertia at the tyre, as
    the simulated trainer's physics has them (within the 1 W resolution, ±0.5 N at 1 m/s)."""
    flywheel = FlywheelParams()
    for speed in (1.0, 3.0, 8.0):
        low, high = calibrated.force_range(speed) or (math.nan, math.nan)
        assert low == pytest.approx(brake_force(flywheel, speed, 0.0), abs=0.5)
        assert high == pytest.approx(brake_force(flywheel, speed, 100.0), abs=0.5)
    assert calibrated.flywheel_mass_eq_kg == pytest.approx(flywheel.mass_eq_kg, rel=0.02)


def test_calibrate_refuses_a_hardware_backend(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", "trainer", "--backend", "ftms"]) == 2
    assert "speed-driving rig" in capsys.readouterr().err
