"""Vehicle parameters, loaded from YAML (`configs/vehicles/*.yaml`).

Every quantity carries its unit in its name. Ranges are checked at load time, so a typo such
as a negative mass fails with the file and field path instead of a NaN at 1 kHz.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import msgspec

from carlaverse.config import StrictStruct, load_config

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Fraction = Annotated[float, msgspec.Meta(ge=0, le=1)]


class Spec(StrictStruct):
    """What the parameter set is tuned to reproduce; the scenario tests check it (± 10 %)."""

    accel_0_100_s: Positive  # [s] full throttle from standstill, automatic
    top_speed_kmh: Positive  # [km/h]


class Body(StrictStruct):
    mass_kg: Positive
    yaw_inertia_kgm2: Positive
    wheelbase_m: Positive
    cg_to_front_axle_m: Positive
    cg_height_m: NonNegative
    length_m: Positive = 4.3
    width_m: Positive = 1.8
    height_m: Positive = 1.5
    drag_area_m2: NonNegative = 0.7  # Cd·A
    air_density_kgm3: Positive = 1.2
    rolling_resistance: NonNegative = 0.011  # rolling-resistance coefficient c_rr [-]


class Tyres(StrictStruct):
    mu: Positive = 1.0  # peak friction coefficient on dry asphalt [-]
    shape_c: Positive = 1.3  # magic-formula shape factor C [-]
    stiffness_b_front: Positive = 11.0  # magic-formula stiffness factor B [1/rad]
    stiffness_b_rear: Positive = 13.0  # [1/rad]; stiffer than the front: mild understeer
    pneumatic_trail_m: Positive = 0.035  # t_p of the self-aligning torque [m]
    radius_m: Positive = 0.31  # rolling radius [m]
    # Below this speed the slip-angle denominator is held (see tyre.py) [m/s].
    slip_speed_min_mps: Positive = 1.0
    wheel_inertia_kgm2: NonNegative = 4.0  # all four wheels together [kg·m²]


class Steering(StrictStruct):
    max_road_wheel_angle_deg: Positive = 35.0  # front wheel angle at full lock [deg]
    ratio: Positive = 15.0  # steering-wheel angle / road-wheel angle [-]


class Engine(StrictStruct, kw_only=True):
    # Full-load torque curve: [rpm, N·m] points, rpm ascending.
    torque_curve: list[tuple[Positive, NonNegative]]
    idle_rpm: Positive = 800.0
    redline_rpm: Positive = 6500.0
    # Drag torque with the throttle closed: c0 + c1·rpm/1000 [N·m] (engine braking).
    drag_torque_nm: tuple[NonNegative, NonNegative] = (10.0, 4.0)
    inertia_kgm2: NonNegative = 0.15  # crank, flywheel and clutch [kg·m²]
    cylinders: Annotated[int, msgspec.Meta(ge=1, le=16)] = 4


class Transmission(StrictStruct, kw_only=True):
    ratios: list[Positive]  # forward gears, first gear first [-]
    mode: Literal["automatic", "manual"] = "automatic"
    reverse_ratio: Positive = 3.5
    final_drive: Positive = 4.0
    efficiency: Fraction = 0.92
    drive_axle: Literal["front", "rear"] = "front"
    shift_time_s: NonNegative = 0.25  # torque interrupted while shifting [s]
    # Automatic shift points, linear in throttle: (at closed throttle, at full throttle) [rpm].
    upshift_rpm: tuple[Positive, Positive] = (2200.0, 6000.0)
    downshift_rpm: tuple[Positive, Positive] = (1100.0, 3000.0)
    # While the clutch slips (launch), the engine is held at idle + throttle·(launch − idle).
    launch_rpm: Positive = 2500.0


class Brakes(StrictStruct):
    max_force_n: Positive = 16000.0  # total braking force at full pedal, before ABS [N]
    front_bias: Fraction = 0.65  # share of braking force on the front axle [-]


class Suspension(StrictStruct):
    """The vertical model (physics/vertical.py): one quarter-car per axle, per kg of the
    sprung mass it carries. Defaults: the "Golden Car" of the International Roughness Index
    (Sayers, Transportation Research Record 1501, 1995), a reference passenger car: body
    bounce at 1.3 Hz, wheel hop at 11 Hz."""

    spring_per_kg: Positive = 63.3  # k_s/m_s [N/m per kg = 1/s²]
    damping_per_kg: Positive = 6.0  # c_s/m_s [N·s/m per kg = 1/s]
    tyre_per_kg: Positive = 653.0  # k_t/m_s [1/s²]
    unsprung_ratio: Positive = 0.15  # m_u/m_s [-]
    track_m: Positive = 1.55  # [m] between the wheels of an axle


class VehicleParams(StrictStruct, kw_only=True):
    """One vehicle: `configs/vehicles/compact-car.yaml` is the reference."""

    name: str
    spec: Spec
    body: Body
    tyres: Tyres = Tyres()
    steering: Steering = Steering()
    engine: Engine
    transmission: Transmission
    brakes: Brakes = Brakes()
    suspension: Suspension = Suspension()
    description: str = ""

    def __post_init__(self) -> None:
        check_consistency(self)


def check_consistency(p: VehicleParams) -> None:
    """Cross-field checks msgspec cannot express; raise ValueError naming the fields."""
    if p.body.cg_to_front_axle_m >= p.body.wheelbase_m:
        raise ValueError("body.cg_to_front_axle_m must be shorter than body.wheelbase_m")
    rpms = [point[0] for point in p.engine.torque_curve]
    if len(rpms) < 2 or rpms != sorted(rpms):
        raise ValueError("engine.torque_curve needs two or more [rpm, N·m] points, rpm ascending")
    if p.engine.idle_rpm >= p.engine.redline_rpm:
        raise ValueError("engine.idle_rpm must be below engine.redline_rpm")
    if not p.transmission.ratios:
        raise ValueError("transmission.ratios needs at least one forward gear")
    up, down = p.transmission.upshift_rpm, p.transmission.downshift_rpm
    if down[0] >= up[0] or down[1] >= up[1]:
        raise ValueError("transmission.downshift_rpm must be below upshift_rpm (hysteresis)")


def load_vehicle(path: str | Path, relative_to: Path | None = None) -> VehicleParams:
    """Load a vehicle file by path or shipped name (`vehicles/compact-car`).

    Range and cross-field errors arrive as ConfigError naming the file and the field.
    """
    return load_config(path, VehicleParams, relative_to)
