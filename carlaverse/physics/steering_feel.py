"""Steering feel: self-aligning torque, the low-speed parking blend, and the FFB command.

Above 15 km/h the wheel carries the front axle's self-aligning torque (paper eq. `pacejka`):
M_z = −F_z·t_p·sin(1.6·atan(8.0·α)), brought to the steering wheel through the steering ratio
and the power-steering assist. Slip angles are meaningless near standstill, so below 15 km/h
the paper fades that torque out in favour of a synthetic, heavy parking spring and friction.
We fade with a smoothstep over [blend_start_kmh, 15 km/h]: the weight and its slope are
continuous, so no field of the FFB command ever steps as the car slows down.

Road shake comes from the same vertical model that heaves the motion platform
(physics/vertical.py): the front wheels' vertical acceleration a_u over the road profile. The
FFB's periodic effect carries a magnitude and a frequency, not a waveform, so the wheel gets
magnitude = road_vibration_per_mps2 · a_u,rms and Rice's mean frequency of a_u,
f = √(mean ȧ_u² / mean a_u²) / 2π (the zero-crossing rate of a random signal), both means
over `road_vibration_window_s`. A smooth road, or a car at rest, shakes nothing; each ISO 8608
roughness class doubles the profile's amplitude, and with it the shake.

Sign conventions. Steering torque τ [N·m] is positive toward the left (counter-clockwise,
like steering angle and yaw). The FFB command follows the hal's wire convention (carlaverse.hal
ffb_packet): constant_force and spring_offset are positive toward the RIGHT, so
constant_force = −τ / full_scale · 10000.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.physics.filters import LowPass, clamp, smoothstep
from carlaverse.physics.impulse import ImpulseResponse
from carlaverse.physics.tyre import self_aligning_torque

FFB_FULL_SCALE = 10000  # the wire value meaning 100 % (see hal.ffb_packet)
FFB_MAX_VIBRATION_HZ = 1000  # [Hz]
KMH = 1.0 / 3.6  # [m/s per km/h]

Units = Annotated[int, msgspec.Meta(ge=0, le=FFB_FULL_SCALE)]
Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class SteeringFeelParams(StrictStruct):
    """The `steering_feel:` section of a drive config. FFB levels in 0..10000 units."""

    full_scale_torque_nm: Positive = 6.0  # steering-wheel torque sent as 100 % [N·m]
    gain: NonNegative = 1.0  # overall strength of the aligning torque [-]
    assist: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.7  # power steering's share [-]
    blend_start_kmh: NonNegative = 3.0  # parking model alone below this speed [km/h]
    blend_end_kmh: Positive = 15.0  # aligning torque alone from this speed (paper) [km/h]
    parking_spring: Units = 6000  # synthetic heavy centring spring at standstill
    parking_friction: Units = 4000  # scrubbing tyres at standstill
    driving_spring: Units = 0  # extra centring on top of the aligning torque
    driving_friction: Units = 600
    damper_low_speed: Units = 1500
    damper_high_speed: Units = 3000  # reached at damper_speed_kmh
    damper_speed_kmh: Positive = 120.0
    inertia: Units = 500
    spring_deadband: Units = 0
    spring_saturation: Units = 10000
    engine_vibration: Units = 150  # at the redline; scaled by rpm/redline
    road_vibration_per_mps2: NonNegative = 80.0  # per m/s² RMS of the front wheel's shake
    road_vibration_window_s: Positive = 0.1  # τ of that RMS and of its frequency [s]
    jolt_force_per_mps: NonNegative = 2500.0  # constant-force kick per 1 m/s lateral Δv
    jolt_vibration_per_mps: NonNegative = 1500.0  # vibration burst per 1 m/s |Δv|
    jolt_decay_s: Positive = 0.12  # e-folding time of the collision jolt [s]
    jolt_frequency_hz: Annotated[int, msgspec.Meta(ge=1, le=FFB_MAX_VIBRATION_HZ)] = 40


@dataclass(slots=True)
class FfbCommandValues:
    """The ten fields of the 40-byte FFB command, in wire order (paper table)."""

    spring_stiffness: int = 0
    spring_offset: int = 0
    spring_deadband: int = 0
    spring_saturation: int = 0
    constant_force: int = 0
    damper: int = 0
    friction: int = 0
    inertia: int = 0
    vibration_magnitude: int = 0
    vibration_frequency_hz: int = 0


def blend_weight(speed_mps: float, start_kmh: float, end_kmh: float) -> float:
    """0 = parking model only, 1 = aligning torque only; C¹-continuous in speed."""
    return smoothstep(start_kmh * KMH, end_kmh * KMH, abs(speed_mps))


class SteeringFeel:
    """Computes one FFB command per loop tick from the chassis and powertrain state."""

    def __init__(
        self,
        params: SteeringFeelParams,
        pneumatic_trail_m: float,
        steering_ratio: float,
        redline_rpm: float,
        cylinders: int,
    ) -> None:
        self.params = params
        self.pneumatic_trail_m = pneumatic_trail_m
        # Steering-wheel torque per contact-patch torque: ratio and assist take their share.
        self._to_wheel = params.gain * (1.0 - params.assist) / steering_ratio
        self._redline = redline_rpm
        self._firings_per_rev = cylinders / 2.0  # four-stroke: each cylinder fires every 2 rev
        self._jolt_force = 0.0  # [units] decaying collision kick
        self._jolt_vibration = 0.0  # [units]
        self.aligning_torque_nm = 0.0  # last steering-wheel torque from M_z [N·m]
        self._shake2 = LowPass(params.road_vibration_window_s)  # mean a_u² [(m/s²)²]
        self._shake_rate2 = LowPass(params.road_vibration_window_s)  # mean ȧ_u² [(m/s³)²]
        self._shake_prev = 0.0  # a_u of the last tick [m/s²]

    def aligning_torque(self, alpha_front: float, fz_front: float) -> float:
        """Self-aligning torque at the steering wheel [N·m], + = toward the left."""
        m_z = self_aligning_torque(fz_front, self.pneumatic_trail_m, alpha_front)
        return m_z * self._to_wheel

    def jolt(self, response: ImpulseResponse) -> None:
        """A collision: kick the wheel toward the shove and add a vibration burst."""
        p = self.params
        self._jolt_force += p.jolt_force_per_mps * response.dvy_body
        self._jolt_vibration += p.jolt_vibration_per_mps * response.magnitude()

    def update(
        self,
        dt: float,
        speed_mps: float,
        alpha_front: float,
        fz_front: float,
        rpm: float,
        wheel_accel_mps2: float = 0.0,
        extra_torque_nm: float = 0.0,
    ) -> FfbCommandValues:
        """One command. wheel_accel_mps2: the front wheels' vertical acceleration over the
        road [m/s²]; extra_torque_nm: e.g. lane keeping, + = toward the left [N·m]."""
        p = self.params
        w = blend_weight(speed_mps, p.blend_start_kmh, p.blend_end_kmh)
        self.aligning_torque_nm = self.aligning_torque(alpha_front, fz_front)
        torque = w * self.aligning_torque_nm + extra_torque_nm
        force = -torque / p.full_scale_torque_nm * FFB_FULL_SCALE + self._jolt_force
        self._track_shake(dt, wheel_accel_mps2)
        magnitude, frequency = self._vibration(rpm)
        self._decay_jolt(dt)
        damper_share = smoothstep(0.0, p.damper_speed_kmh * KMH, abs(speed_mps))
        return FfbCommandValues(
            spring_stiffness=_units(p.parking_spring + w * (p.driving_spring - p.parking_spring)),
            spring_offset=0,
            spring_deadband=p.spring_deadband,
            spring_saturation=p.spring_saturation,
            constant_force=_signed_units(force),
            damper=_units(
                p.damper_low_speed + damper_share * (p.damper_high_speed - p.damper_low_speed)
            ),
            friction=_units(p.parking_friction + w * (p.driving_friction - p.parking_friction)),
            inertia=p.inertia,
            vibration_magnitude=_units(magnitude),
            vibration_frequency_hz=int(clamp(round(frequency), 0, FFB_MAX_VIBRATION_HZ)),
        )

    def _track_shake(self, dt: float, accel: float) -> None:
        """Running means of a_u² and ȧ_u² over the road-vibration window."""
        rate = (accel - self._shake_prev) / dt
        self._shake_prev = accel
        self._shake2.update(accel * accel, dt)
        self._shake_rate2.update(rate * rate, dt)

    def _vibration(self, rpm: float) -> tuple[float, float]:
        """Engine firing rumble and road shake; the stronger one sets the frequency."""
        p = self.params
        engine_mag = p.engine_vibration * clamp(rpm / self._redline, 0.0, 1.0)
        engine_hz = rpm / 60.0 * self._firings_per_rev
        mean2 = self._shake2.value
        road_mag = p.road_vibration_per_mps2 * math.sqrt(mean2)
        road_hz = math.sqrt(self._shake_rate2.value / mean2) / (2.0 * math.pi) if mean2 else 0.0
        magnitude, frequency = (
            (engine_mag, engine_hz) if engine_mag >= road_mag else (road_mag, road_hz)
        )
        if self._jolt_vibration > magnitude:
            magnitude, frequency = self._jolt_vibration, float(p.jolt_frequency_hz)
        return magnitude, frequency

    def _decay_jolt(self, dt: float) -> None:
        if self._jolt_force or self._jolt_vibration:
            k = math.exp(-dt / self.params.jolt_decay_s)
            self._jolt_force *= k
            self._jolt_vibration *= k
            if abs(self._jolt_force) < 1.0 and self._jolt_vibration < 1.0:
                self._jolt_force = self._jolt_vibration = 0.0


def _units(value: float) -> int:
    return int(clamp(round(value), 0, FFB_FULL_SCALE))


def _signed_units(value: float) -> int:
    return int(clamp(round(value), -FFB_FULL_SCALE, FFB_FULL_SCALE))
