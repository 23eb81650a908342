"""What the rider feels through the fork: trail self-centering, road texture, impulse jolts.

The front contact patch trails the steering axis by the trail t, so the ground's lateral
force on a turning wheel pulls the fork back to centre. In a steady turn that force is the
front wheel's share of the centripetal force, m_f·v²·κ, acting on the lever t:

    M_center ≈ −t · m_f · (g · sin δ + v² · tan δ / L)

(the g term is the wheel flop of a stationary front; the v² term grows with speed). It goes to
the FFB server as a constant force scaled by `full_scale_nm`. Road texture is a vibration
whose amplitude grows with speed and the surface's roughness; a collision impulse adds a jolt —
a strong vibration and a kick against the fork — that fades within `jolt_decay_s`.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.ffb_packet import FULL_SCALE, FfbCommand
from carlaverse.physics.bicycle import G_MPS2, BicycleParams

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class ForkFeelParams(StrictStruct):
    trail_m: Positive = 0.06  # [m] city-bike trail
    front_load_kg: Positive = 35.0  # [kg] the front wheel's share of bike + rider
    full_scale_nm: Positive = 8.0  # [N·m] torque at FFB full scale (the fork motor's limit)
    damper: Annotated[int, msgspec.Meta(ge=0, le=FULL_SCALE)] = 800  # light viscous feel
    texture_gain: NonNegative = 600.0  # vibration per (m/s · roughness), 0..10000 scale
    texture_hz: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 40  # [Hz] road texture
    jolt_gain: NonNegative = 3000.0  # vibration + kick per m/s of impulse Δv
    jolt_hz: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 25  # [Hz]
    jolt_decay_s: Positive = 0.15  # [s] time constant of a jolt's fade


def centering_torque(p: ForkFeelParams, bike: BicycleParams, speed_mps: float,
                     steer_rad: float) -> float:  # fmt: skip
    """M_center [N·m], negative for a positive (left) fork angle: it pulls back to centre."""
    lateral = G_MPS2 * math.sin(steer_rad) + speed_mps**2 * math.tan(steer_rad) / bike.wheelbase_m
    return -p.trail_m * p.front_load_kg * lateral


class ForkFeel:
    """Turns the bike's state into the fork motor's FFB command, once per haptics tick."""

    def __init__(self, params: ForkFeelParams, bike: BicycleParams) -> None:
        self.params = params
        self.bike = bike
        self.jolt = 0.0  # [0..10000] current jolt strength
        self.kick = 0.0  # signed kick, same scale

    def add_jolt(self, dv_mps: float, dv_lateral_mps: float) -> None:
        """A collision: |Δv| [m/s] sets the jolt, the lateral part its direction."""
        strength = min(float(FULL_SCALE), self.params.jolt_gain * abs(dv_mps))
        self.jolt = max(self.jolt, strength)
        self.kick = math.copysign(strength, dv_lateral_mps or 1.0)

    def update(self, dt: float, speed_mps: float, steer_rad: float,
               roughness: float) -> FfbCommand:  # fmt: skip
        p = self.params
        torque = centering_torque(p, self.bike, speed_mps, steer_rad)
        force = torque / p.full_scale_nm * FULL_SCALE + self.kick
        texture = p.texture_gain * speed_mps * roughness
        jolting = self.jolt > texture
        command = FfbCommand(
            constant_force=_clamp(force, -FULL_SCALE, FULL_SCALE),
            damper=p.damper,
            vibration_magnitude=_clamp(max(texture, self.jolt), 0, FULL_SCALE),
            vibration_frequency_hz=p.jolt_hz if jolting else p.texture_hz,
        )
        fade = math.exp(-dt / p.jolt_decay_s)
        self.jolt *= fade
        self.kick *= fade
        return command


def _clamp(value: float, low: int, high: int) -> int:
    return max(low, min(high, round(value)))
