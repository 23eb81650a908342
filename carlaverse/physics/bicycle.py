"""Single-track kinematic bicycle: the CycloCARLA ego model.

The rider's wheel gives the speed v (trainer or wheel-speed sensor), the fork gives the steer
angle δ; the model integrates the pose. Reference point is the centre of gravity, a distance
l_r ahead of the rear contact point, so the body slips by β = atan(l_r/L · tan δ):

    ẋ = v cos(ψ + β),  ẏ = v sin(ψ + β),  ψ̇ = v cos β tan δ / L

The stationary frame cannot lean, so the lean φ the renderer shows is the steady-turn
balance of gravity and centripetal force: tan φ = v²·κ/g with path curvature κ = ψ̇/v.

Collision impulses (decided by the authority) act on the bike: a small one changes the
speed for a moment and pushes the bike sideways (the push decays, a rider catches it); a
forward knock-back stops the bike; a violent one (|Δv| above `fall_dv_mps`) throws it: the
bike lies on the side the impulse pushed it to and the rider stays down for `fall_hold_s`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.support.angles import wrap_angle

G_MPS2 = 9.81  # [m/s²]
Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class BicycleParams(StrictStruct):
    """A city bike with its rider; every quantity in the unit its name says."""

    mass_kg: Positive = 90.0  # rider + bike
    wheelbase_m: Positive = 1.08
    cg_to_rear_m: Positive = 0.45  # centre of gravity ahead of the rear contact
    length_m: Positive = 1.8
    width_m: Positive = 0.65
    height_m: Positive = 1.7
    head_height_m: Positive = 1.6  # rider's eyes above the road, for the first-person view
    max_steer_rad: Positive = 0.6  # fork angle at full lock
    max_lean_rad: Positive = 0.785  # 45°: beyond this a real rider slides out
    fall_dv_mps: Positive = 3.0  # an impulse changing speed this much throws the bike
    stop_hold_s: NonNegative = 1.0  # a knock-back holds the bike still this long
    fall_hold_s: NonNegative = 3.0  # a fallen rider stays down this long
    push_decay_s: Positive = 0.3  # a sideways push fades with this time constant
    # How fast the bike's speed may follow the wheel's reading. A trainer or sensor reports
    # in steps (BLE: 1-4 Hz; a sim profile: jumps), and a 0.25 m/s step taken in one 5 ms tick
    # is 50 m/s² in the pose (0.15 -> 2.67 m/s in one tick was seen: 503 m/s²), which every
    # receiver's dead reckoning then projects. The body cannot do that: a sprint from rest is
    # about 2.5 m/s², and braking is bounded near 0.6 g by the rider pitching over the front
    # wheel (Wilson, Bicycling Science, 3rd ed., ch. 7), below the tyres' friction μg.
    # (`WheelReading` applies them to what the sensor says, before `Bicycle.step`.)
    max_accel_mps2: Positive = 3.0
    max_decel_mps2: Positive = 6.0


@dataclass(slots=True)
class BicycleState:
    x: float = 0.0  # [m] centre of gravity, world frame
    y: float = 0.0  # [m]
    yaw: float = 0.0  # [rad] heading, counter-clockwise from +x
    speed_mps: float = 0.0  # [m/s] along the heading (what the wheel says, after impulses)
    steer_rad: float = 0.0  # [rad] fork angle, positive turns left (like yaw)
    yaw_rate: float = 0.0  # [rad/s]
    lean_rad: float = 0.0  # [rad] positive leans left (into a left turn)
    vx: float = 0.0  # [m/s] world-frame velocity of the CG, including pushes
    vy: float = 0.0  # [m/s]
    ax: float = 0.0  # [m/s²] world frame
    ay: float = 0.0  # [m/s²]
    fallen: bool = False
    hold_s: float = 0.0  # [s] left of a stop or a fall


@dataclass(frozen=True, slots=True)
class BikeImpulse:
    """What one impulse did, for the fork's jolt."""

    dv_forward_mps: float  # [m/s]
    dv_lateral_mps: float  # [m/s] positive to the left
    fell: bool

    def magnitude(self) -> float:
        return math.hypot(self.dv_forward_mps, self.dv_lateral_mps)


def lean_angle(speed_mps: float, yaw_rate: float, max_lean_rad: float) -> float:
    """Steady-turn lean [rad]: tan φ = v²κ/g = v·ψ̇/g, clamped to the rider's limit."""
    lean = math.atan(speed_mps * yaw_rate / G_MPS2)
    return max(-max_lean_rad, min(max_lean_rad, lean))


class Bicycle:
    """The ego bicycle; `step` once per loop tick with the wheel speed and the fork angle."""

    def __init__(self, params: BicycleParams) -> None:
        self.params = params
        self.state = BicycleState()
        self._push = [0.0, 0.0]  # [m/s] world-frame velocity from impulses, decaying
        self._dv_forward = 0.0  # [m/s] forward speed change from impulses, decaying

    def place(self, x: float, y: float, yaw: float) -> None:
        """Put the bike at a spawn pose, upright and at rest."""
        self.state = BicycleState(x=x, y=y, yaw=yaw)
        self._push = [0.0, 0.0]
        self._dv_forward = 0.0

    def step(self, dt: float, wheel_speed_mps: float, steer_rad: float) -> BicycleState:
        """Advance dt [s] with the rider's wheel speed [m/s] and fork angle [rad]."""
        s, p = self.state, self.params
        held = s.hold_s > 0.0
        s.hold_s = max(0.0, s.hold_s - dt)
        if not held and s.fallen:
            s.fallen = False  # back on the bike
        steer = max(-p.max_steer_rad, min(p.max_steer_rad, steer_rad))
        speed = 0.0 if held else max(0.0, wheel_speed_mps + self._dv_forward)
        beta = math.atan(p.cg_to_rear_m / p.wheelbase_m * math.tan(steer))
        yaw_rate = speed * math.cos(beta) * math.tan(steer) / p.wheelbase_m
        vx = speed * math.cos(s.yaw + beta) + self._push[0]
        vy = speed * math.sin(s.yaw + beta) + self._push[1]
        s.ax, s.ay = (vx - s.vx) / dt, (vy - s.vy) / dt
        s.vx, s.vy = vx, vy
        s.x += vx * dt
        s.y += vy * dt
        s.yaw = wrap_angle(s.yaw + yaw_rate * dt)
        s.speed_mps, s.steer_rad, s.yaw_rate = speed, steer, yaw_rate
        if not s.fallen:
            s.lean_rad = lean_angle(speed, yaw_rate, p.max_lean_rad)
        self._decay(dt)
        return s

    def apply_impulse(self, impulse_ns: tuple[float, float, float]) -> BikeImpulse:
        """Apply a world-frame impulse J [N·s] at the bike (planar part only)."""
        s, p = self.state, self.params
        c, si = math.cos(s.yaw), math.sin(s.yaw)
        dv_fwd = (impulse_ns[0] * c + impulse_ns[1] * si) / p.mass_kg
        dv_lat = (-impulse_ns[0] * si + impulse_ns[1] * c) / p.mass_kg
        fell = math.hypot(dv_fwd, dv_lat) >= p.fall_dv_mps
        if fell:
            s.fallen = True
            s.hold_s = max(s.hold_s, p.fall_hold_s)
            s.lean_rad = math.copysign(math.pi / 2, dv_lat or 1.0)  # lies where pushed
        elif dv_fwd < 0 and s.speed_mps + dv_fwd <= 0.0:
            s.hold_s = max(s.hold_s, p.stop_hold_s)  # knocked back to a standstill
        else:
            self._dv_forward += dv_fwd
        self._push[0] += -dv_lat * si
        self._push[1] += dv_lat * c
        return BikeImpulse(dv_fwd, dv_lat, fell)

    def _decay(self, dt: float) -> None:
        keep = math.exp(-dt / self.params.push_decay_s)
        self._push[0] *= keep
        self._push[1] *= keep
        self._dv_forward *= keep


class WheelReading:
    """The wheel speed a trainer or sensor reports, as the bike can follow it: each tick it
    moves toward the reading by at most `max_accel_mps2` (`max_decel_mps2` slowing) × dt,
    so a step in the reading becomes a ramp the rider's body could ride (see the params).
    The first reading after a start or a `reset` (a spawn) is taken as it is: it is how fast
    the rider already goes, not a change."""

    def __init__(self, params: BicycleParams) -> None:
        self.params = params
        self.mps: float | None = None

    def reset(self) -> None:
        self.mps = None

    def follow(self, reading_mps: float, dt: float, stopped: bool = False) -> float:
        """The speed to ride this tick; `stopped`: the bike is held still (a fall, a knock),
        and rides on from rest."""
        p, reading = self.params, max(0.0, reading_mps)
        if stopped:
            self.mps = 0.0
        elif self.mps is None:
            self.mps = reading
        else:
            step = max(-p.max_decel_mps2 * dt, min(p.max_accel_mps2 * dt, reading - self.mps))
            self.mps = max(0.0, self.mps + step)
        return self.mps
