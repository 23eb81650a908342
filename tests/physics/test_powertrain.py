"""Powertrain and chassis details: gears, clutch, launch, reverse, load transfer, step size."""

from __future__ import annotations

import msgspec
import pytest
import yaml

from carlaverse.config import ConfigError
from carlaverse.physics.car import Car
from carlaverse.physics.params import VehicleParams, load_vehicle
from carlaverse.physics.powertrain import RADPS_TO_RPM, Powertrain
from tests.physics.vehicles import VEHICLES_DIR

DT = 0.001  # [s]


def manual(params: VehicleParams) -> VehicleParams:
    transmission = msgspec.structs.replace(params.transmission, mode="manual")
    return msgspec.structs.replace(params, transmission=transmission)


def test_automatic_upshifts_in_order_at_full_throttle(compact_car: VehicleParams) -> None:
    car = Car(compact_car)
    car.powertrain.shift_up()  # N → D
    gears = [car.powertrain.gear]
    for _ in range(40_000):
        car.step(DT, 0.0, 1.0, 0.0)
        if car.powertrain.gear != gears[-1]:
            gears.append(car.powertrain.gear)
        assert car.powertrain.rpm <= compact_car.engine.redline_rpm + 1.0
    assert gears == [1, 2, 3, 4, 5]  # 6th is an overdrive the schedule needs no throttle for


def test_automatic_downshifts_as_the_car_stops(compact_car: VehicleParams) -> None:
    car = Car(compact_car)
    car.powertrain.select(5)
    car.place(0.0, 0.0, 0.0, 30.0)
    for _ in range(10_000):
        car.step(DT, 0.0, 0.0, 0.5)
    assert car.state.vx == 0.0 and car.powertrain.gear == 1


def test_manual_gears_clutch_and_launch(compact_car: VehicleParams) -> None:
    car = Car(manual(compact_car))
    pt = car.powertrain
    pt.shift_up()
    pt.shift_up()
    assert pt.gear == 2  # N → 1 → 2, no automatic
    for _ in range(2_000):  # clutch pressed: the engine revs, the car stays
        car.step(DT, 0.0, 1.0, 0.0, clutch=1.0)
    assert car.state.vx == 0.0 and pt.rpm > 3000.0
    for _ in range(3_000):  # released: a slipping launch in 2nd, no stall
        car.step(DT, 0.0, 0.6, 0.0, clutch=0.0)
    assert car.state.vx > 3.0 and pt.rpm >= compact_car.engine.idle_rpm
    for _ in range(20_000):
        car.step(DT, 0.0, 1.0, 0.0)
    assert pt.gear == 2  # a manual box never shifts by itself ...
    assert pt.rpm == pytest.approx(
        compact_car.engine.redline_rpm, rel=0.02
    )  # ... it hits the limiter


def test_reverse_only_when_nearly_stopped(compact_car: VehicleParams) -> None:
    pt = Powertrain(compact_car.engine, compact_car.transmission)
    pt.shift_down(forward_speed_mps=5.0)  # N → R refused while rolling forward
    assert pt.gear == 0
    pt.shift_down(forward_speed_mps=0.2)
    assert pt.gear == -1
    car = Car(compact_car)
    car.powertrain.select(-1)
    for _ in range(3_000):
        car.step(DT, 0.0, 0.4, 0.0)
    assert car.state.vx < -1.0  # reversing


def test_engine_follows_the_wheels_when_coupled(compact_car: VehicleParams) -> None:
    car = Car(manual(compact_car))  # manual: no upshift interrupting the measurement
    car.powertrain.select(3)
    car.place(0.0, 0.0, 0.0, 20.0)
    car.step(DT, 0.0, 0.3, 0.0)
    t = compact_car.transmission
    expected = car.state.vx / compact_car.tyres.radius_m * t.ratios[2] * t.final_drive
    assert car.powertrain.rpm == pytest.approx(expected * RADPS_TO_RPM, rel=1e-3)


def test_braking_moves_load_to_the_front_axle(compact_car: VehicleParams) -> None:
    car = Car(compact_car)
    car.place(0.0, 0.0, 0.0, 20.0)
    static_front = car.state.fz_front
    for _ in range(300):
        car.step(DT, 0.0, 0.0, 1.0)
    body = compact_car.body
    shift = body.mass_kg * -car.state.ax * body.cg_height_m / body.wheelbase_m  # [N]
    # Within 2 %: the load transfer lags a_x through its 20 ms filter, settled after 0.3 s.
    assert car.state.fz_front - static_front == pytest.approx(shift, rel=0.02)
    assert car.state.fz_front + car.state.fz_rear == pytest.approx(body.mass_kg * 9.81)


def test_a_coarser_loop_rate_gives_the_same_car(compact_car: VehicleParams) -> None:
    def zero_to_hundred(dt: float) -> float:
        car = Car(compact_car)
        car.powertrain.shift_up()
        t = 0.0
        while car.state.vx < 100 / 3.6:
            car.step(dt, 0.0, 1.0, 0.0)
            t += dt
        return t

    # 250 Hz vs 1 kHz: the same 0-100 time within 1 % (Euler's O(dt) error plus one step).
    assert zero_to_hundred(0.004) == pytest.approx(zero_to_hundred(DT), rel=0.01)


@pytest.mark.parametrize(
    ("section", "field", "value", "message"),
    [
        ("body", "mass_kg", -5, r"body\.mass_kg"),
        ("body", "cg_to_front_axle_m", 9.0, "shorter than body.wheelbase_m"),
        ("engine", "torque_curve", [[3000, 100], [1000, 120]], "rpm ascending"),
        ("transmission", "downshift_rpm", [2500, 6500], "hysteresis"),
        ("tyres", "grip", 1.0, "unknown field"),
    ],
)
def test_vehicle_errors_name_the_file_and_field(tmp_path, section, field, value, message):
    data = yaml.safe_load((VEHICLES_DIR / "compact-car.yaml").read_text())
    data[section][field] = value
    path = tmp_path / "broken-car.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=message) as info:
        load_vehicle(path)
    assert "broken-car.yaml" in str(info.value)
