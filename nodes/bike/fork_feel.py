"""What the rider feels through the fork: the upright bicycle's steer torque, road texture,
impulse jolts.

The steer torque is the steer row of the linearised Whipple bicycle (Meijaard, Papadopoulos,
Ruina & Schwab 2007, "Linearized dynamics equations for the balance and steer of a bicycle: a
benchmark and review", Proc. R. Soc. A 463, M·q̈ + v·C1·q̇ + (g·K0 + v²·K2)·q = f) with the
frame upright: the stationary frame cannot lean, so the rider balances with the bar alone
(paper, CycloCARLA) and feels the fork's own stiffness. Held at δ, the fork pushes back with

    τ = −(g·K0δδ + v²·K2δδ)·δ,    K0δδ = −S_A·sin λ,    K2δδ = (S_A + S_F·sin λ)·cos λ / w
    S_A = m_f·c·cos λ + m_A·u_A    the front load m_f = m·l_r/w on the normal trail c·cos λ,
                                   plus the front assembly's own mass offset [kg·m]
    S_F = I_Fyy / r_F              the spinning front wheel [kg·m]

with λ the steer axis's tilt from vertical (90° − head angle) and w the wheelbase. τ and δ
are positive toward the LEFT (counter-clockwise from above, like yaw). The two terms pull
opposite ways:

- wheel flop, +g·S_A·sin λ·sin δ: the front load drops the head of the frame as the fork
  turns, so gravity turns the wheel further INTO the steer (it flops a parked bike's bar);
- trail, −v²·(S_A + S_F·sin λ)·cos λ/w·tan δ: the front tyre's share of the centripetal force
  acts on the trail behind the steer axis and pulls the fork back to centre, with the front
  wheel's gyroscopic precession.

The trail wins above v₀ = √(g·w·tan λ · S_A/(S_A + S_F·sin λ)), 1.9 m/s for the default city
bike (λ = 20°, c = 6 cm, 37.5 kg on the front wheel); below it the bar flops. Sized against
measured riding: riders apply a few N·m (Moore's Davis instrumented bicycle; Cain, Ashton-
Miller & Perkins 2016, PLoS ONE 11(2) e0149340); the defaults give 2.1 N·m at 5 m/s and
0.05 rad (a 23 m turn) and 4.1 N·m at 0.1 rad (an 11.5 m turn at 2.2 m/s², above the measured
band). A real bike in a steady turn needs less, because its lean, g·K0δφ·φ, cancels most of
the trail's pull; upright, that part is what the rider steers against. The motor's
`full_scale_nm` bounds it (full lock at 5 m/s would be 29 N·m).

The torque goes to the FFB server as a constant force scaled by `full_scale_nm`, on the
wire's convention (positive toward the right, `carlaverse.hal.ffb_packet`). Road texture is a
vibration growing with speed and the surface's roughness. A collision impulse adds a jolt: a
strong vibration and a kick of the bar toward where the bike was pushed (the ground holds the
contact patch, which trails the steer axis, so the wheel turns like a caster toward the push),
fading within `jolt_decay_s`.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.ffb_packet import FULL_SCALE, FfbCommand, constant_force
from carlaverse.physics.bicycle import G_MPS2, BicycleParams

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class ForkFeelParams(StrictStruct):
    trail_m: Positive = 0.06  # c [m], city bike
    steer_axis_tilt_rad: Annotated[float, msgspec.Meta(ge=0, lt=1.2)] = 0.35  # λ: 70° head
    front_assembly_offset_kgm: float = 0.0  # m_A·u_A [kg·m] bar+fork+wheel ahead of the axis
    front_wheel_spin_inertia_kgm2: NonNegative = 0.1  # I_Fyy [kg·m²], a city wheel and tyre
    front_wheel_radius_m: Positive = 0.35  # r_F [m]
    full_scale_nm: Positive = 8.0  # [N·m] torque at FFB full scale (the fork motor's limit)
    damper: Annotated[int, msgspec.Meta(ge=0, le=FULL_SCALE)] = 800  # light viscous feel
    texture_gain: NonNegative = 600.0  # vibration per (m/s · roughness), 0..10000 scale
    texture_hz: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 40  # [Hz] road texture
    jolt_gain: NonNegative = 3000.0  # vibration + kick per m/s of impulse Δv, 0..10000 scale
    jolt_hz: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 25  # [Hz]
    jolt_decay_s: Positive = 0.15  # [s] time constant of a jolt's fade


def trail_lever_kgm(p: ForkFeelParams, bike: BicycleParams) -> float:
    """S_A [kg·m]: the front wheel's load on the normal trail plus the front assembly's offset."""
    front_load_kg = bike.mass_kg * bike.cg_to_rear_m / bike.wheelbase_m
    return front_load_kg * p.trail_m * math.cos(p.steer_axis_tilt_rad) + p.front_assembly_offset_kgm


def wheel_flop_torque(p: ForkFeelParams, bike: BicycleParams, steer_rad: float) -> float:
    """Gravity's torque on the fork [N·m], same sign as δ: it turns the wheel further in."""
    return G_MPS2 * trail_lever_kgm(p, bike) * math.sin(p.steer_axis_tilt_rad) * math.sin(steer_rad)


def trail_torque(p: ForkFeelParams, bike: BicycleParams, speed_mps: float,
                 steer_rad: float) -> float:  # fmt: skip
    """The tyre's cornering force on the trail, and the wheel's precession [N·m], against δ."""
    lam = p.steer_axis_tilt_rad
    gyro_kgm = p.front_wheel_spin_inertia_kgm2 / p.front_wheel_radius_m * math.sin(lam)
    stiffness = (trail_lever_kgm(p, bike) + gyro_kgm) * math.cos(lam) / bike.wheelbase_m
    return -(speed_mps**2) * stiffness * math.tan(steer_rad)


def steer_torque(p: ForkFeelParams, bike: BicycleParams, speed_mps: float,
                 steer_rad: float) -> float:  # fmt: skip
    """τ [N·m] the upright bicycle's fork exerts at fork angle δ, positive toward the left."""
    return wheel_flop_torque(p, bike, steer_rad) + trail_torque(p, bike, speed_mps, steer_rad)


class ForkFeel:
    """Turns the bike's state into the fork motor's FFB command, once per haptics tick."""

    def __init__(self, params: ForkFeelParams, bike: BicycleParams) -> None:
        self.params = params
        self.bike = bike
        self.jolt = 0.0  # [0..10000] current jolt strength
        self.kick_nm = 0.0  # [N·m] the jolt's kick on the bar, positive toward the left

    def add_jolt(self, dv_mps: float, dv_lateral_mps: float) -> None:
        """A collision: |Δv| [m/s] sets the jolt; the bar is kicked the way the lateral part
        pushed the bike (Δv_lateral > 0: to the left)."""
        strength = min(float(FULL_SCALE), self.params.jolt_gain * abs(dv_mps))
        self.jolt = max(self.jolt, strength)
        kick_nm = strength / FULL_SCALE * self.params.full_scale_nm
        self.kick_nm = math.copysign(kick_nm, dv_lateral_mps or 1.0)

    def update(self, dt: float, speed_mps: float, steer_rad: float,
               roughness: float) -> FfbCommand:  # fmt: skip
        """The command for one tick of dt [s] at the wheel speed [m/s] and fork angle [rad]."""
        p = self.params
        torque = steer_torque(p, self.bike, speed_mps, steer_rad) + self.kick_nm
        texture = p.texture_gain * speed_mps * roughness
        jolting = self.jolt > texture
        command = FfbCommand(
            constant_force=constant_force(torque, p.full_scale_nm),
            damper=p.damper,
            vibration_magnitude=_clamp(max(texture, self.jolt), 0, FULL_SCALE),
            vibration_frequency_hz=p.jolt_hz if jolting else p.texture_hz,
        )
        fade = math.exp(-dt / p.jolt_decay_s)
        self.jolt *= fade
        self.kick_nm *= fade
        return command


def _clamp(value: float, low: int, high: int) -> int:
    return max(low, min(high, round(value)))
