"""A four-wheeled car: single-track chassis + powertrain + brakes, driven by pedal inputs.

The glue between the driver's normalised commands and the forces the chassis integrates.
Wheel slip is not modelled longitudinally: the driven wheels turn at v/r, and the drive force
is capped at the axle's grip (traction control, as on every car the shipped configs model).
"""

from __future__ import annotations

import math

from carlaverse.physics.impulse import ImpulseResponse, apply_impulse
from carlaverse.physics.params import VehicleParams
from carlaverse.physics.powertrain import Powertrain
from carlaverse.physics.single_track import ChassisState, SingleTrack


class Car:
    """Vehicle physics for one ego car. `step` once per loop tick (or physics sub-step)."""

    def __init__(self, params: VehicleParams) -> None:
        self.params = params
        self.chassis = SingleTrack(params.body, params.tyres, params.brakes.front_bias)
        self.powertrain = Powertrain(params.engine, params.transmission)
        self.wheel_radius_m = params.tyres.radius_m
        self.max_steer_rad = math.radians(params.steering.max_road_wheel_angle_deg)
        self._front_drive = params.transmission.drive_axle == "front"
        self._wheel_mass = params.tyres.wheel_inertia_kgm2 / self.wheel_radius_m**2  # [kg]

    @property
    def state(self) -> ChassisState:
        return self.chassis.state

    def place(self, x: float, y: float, yaw: float, speed_mps: float = 0.0) -> None:
        """Put the car at a pose (e.g. the spawn point), moving forward at speed_mps."""
        s = self.chassis.state
        s.x, s.y, s.yaw = x, y, yaw
        s.vx, s.vy, s.yaw_rate = speed_mps, 0.0, 0.0

    def step(
        self,
        dt: float,
        steer: float,
        throttle: float,
        brake: float,
        clutch: float = 0.0,
        mu_scale: float = 1.0,
    ) -> None:
        """Advance dt [s]. steer −1..1 (+ = left), throttle/brake/clutch pedals 0..1."""
        radius = self.wheel_radius_m
        wheel_torque = self.powertrain.step(dt, throttle, clutch, self.chassis.state.vx / radius)
        drive = wheel_torque / radius
        extra_mass = self._wheel_mass + self.powertrain.reflected_inertia_kgm2 / radius**2
        self.chassis.step(
            dt,
            steer * self.max_steer_rad,
            drive if self._front_drive else 0.0,
            0.0 if self._front_drive else drive,
            brake * self.params.brakes.max_force_n,
            extra_mass,
            mu_scale,
        )

    def apply_impulse(
        self, impulse_ns: tuple[float, float, float], point_m: tuple[float, float, float]
    ) -> ImpulseResponse:
        body = self.params.body
        return apply_impulse(
            self.chassis.state, impulse_ns, point_m, body.mass_kg, body.yaw_inertia_kgm2
        )
