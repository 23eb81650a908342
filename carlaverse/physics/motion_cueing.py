"""Signal-based motion cueing for a 3-DOF (pitch, roll, heave) platform (paper, "Motion Cueing").

Pipeline per axis, as in the paper's figure: first-order low-pass on a_x, a_y, a_z →
cue formula → washout → clamp to the platform's limits.

    pitch θ = a_x,LPF / a_ref · f_scale(v) + k_b · b_LPF + k_impulse · ḃ  (+ k_road · θ̃_road)
    roll  φ = a_y,LPF / a_y,ref + k_s · s_LPF
    heave z = k_jx · j̃_x + k_jz · j̃_z + z_brake        (+ collision jolts)

j̃ are the jerks of the filtered accelerations after deadband, clamp and low-pass; z_brake is
a negative half-sine heave impulse fired once per emergency brake application; ḃ is the rate
of the filtered brake pedal (the raw pedal's rate is unbounded on a keyboard).

The road reaches the platform through a_z — the body's vertical acceleration over the road
profile (physics/vertical.py), whose jerk drives the heave as the paper intends for "curbs or
road bumps" — and through θ_road, the body's pitch over the profile (front axle up: nose up),
which the paper's pitch equation lacks: on a kerb or a bump the car really tilts, and a
platform that heaves without tilting misplaces the bump. k_road = 0 gives the paper's θ.
θ̃_road is θ_road through a first-order high-pass (τ = road_pitch_washout_s): a car standing
on an uneven road sits a little pitched for as long as it stands, and a tilt held with
nothing happening is a false cue, so only the change of the road's pitch is cued.

Washout: a sustained acceleration keeps its tilt (the point of tilt coordination on a 3-DOF
rig), and when the event ends each axis returns to neutral ("after an acceleration event",
the paper) with a time constant that grows with speed — quick and firm at a standstill,
gentle on the motorway. The filter is asymmetric: a cue growing away from neutral follows
the formula with a short attack lag; a cue shrinking toward neutral decays at the washout
rate. It therefore never overshoots neutral (no false cue in the opposite direction) and is
continuous everywhere.
`washout_*_s` is the time to get back within ~2 % of the cue (τ = time/4).

A stop ends the braking event: the pedal terms k_b·b_LPF + k_impulse·ḃ are weighted by
smoothstep(0, scale_speed_start_mps, |v|), so with the car at rest and the pedal still down
the nose-down cue washes out like any other (τ = washout_low_speed_s/4) instead of being held
for as long as the driver waits at the light. The paper's pitch equation has no such weight;
its washout sentence decides it: a held pedal at rest is no acceleration to keep a tilt for.

Units follow the motion packet (carlaverse.hal.motion_packet): roll [rad] right side down
positive, pitch [rad] nose up positive, heave [m] up positive. Body frame x forward, y left:
accelerating (a_x > 0) pitches nose up, a left turn (a_y > 0) rolls right side down, braking
needs negative k_b and k_impulse to dip the nose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.physics.filters import LowPass, clamp, deadband, lpf_alpha, smoothstep
from carlaverse.physics.impulse import ImpulseResponse

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
MAX_PULSES = 4  # concurrent half-sine cues (brake + collisions); more are merged away


class MotionCueingParams(StrictStruct):
    """The `motion_cueing:` section of a drive config; every gain of the MCA."""

    accel_lpf_s: NonNegative = 0.1  # τ of the a_x, a_y, a_z low-pass [s]
    a_ref_mps2_per_rad: Positive = 40.0  # a_ref: longitudinal accel per rad of pitch
    ay_ref_mps2_per_rad: Positive = 40.0  # a_y,ref: lateral accel per rad of roll
    scale_speed_start_mps: NonNegative = 0.3  # f_scale(v) = 0 below [m/s]
    scale_speed_full_mps: Positive = 3.0  # f_scale(v) = 1 above [m/s]
    k_brake_rad: float = -0.02  # k_b: pitch per unit filtered brake pedal [rad]
    k_brake_rate_rad_s: float = -0.004  # k_impulse: pitch per pedal rate [rad·s]
    k_road_pitch: float = 1.0  # k_road: platform pitch per body pitch over the road [rad/rad]
    road_pitch_washout_s: Positive = 1.0  # τ of θ_road's high-pass [s]
    brake_lpf_s: NonNegative = 0.08  # [s]
    k_steer_rad: float = 0.015  # k_s: roll per unit filtered steer input [rad]
    steer_lpf_s: NonNegative = 0.15  # [s]
    jerk_deadband_mps3: NonNegative = 1.5  # [m/s³]
    jerk_clamp_mps3: Positive = 40.0  # [m/s³]
    jerk_lpf_s: NonNegative = 0.05  # [s]
    k_jx_m_per_mps3: float = 0.0004  # heave per longitudinal jerk [m/(m/s³)]
    k_jz_m_per_mps3: float = 0.001  # heave per vertical jerk [m/(m/s³)]
    emergency_brake_pedal: Annotated[float, msgspec.Meta(gt=0, le=1)] = 0.8  # trigger level
    emergency_brake_rate_per_s: Positive = 3.0  # and filtered pedal rate above this [1/s]
    emergency_brake_rearm_pedal: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.2
    emergency_heave_m: float = -0.015  # z_brake amplitude (negative: a dip) [m]
    emergency_heave_s: Positive = 0.35  # z_brake duration [s]
    collision_heave_m_per_mps: float = 0.006  # heave jolt per |Δv| [m/(m/s)]
    collision_pitch_rad_per_mps: float = 0.02  # pitch kick per forward Δv [rad/(m/s)]
    collision_roll_rad_per_mps: float = 0.02  # roll kick per leftward Δv [rad/(m/s)]
    collision_pulse_s: Positive = 0.15  # [s]
    attack_s: NonNegative = 0.03  # lag of a cue growing away from neutral [s]
    washout_low_speed_s: Positive = 1.0  # return time at standstill [s]
    washout_high_speed_s: Positive = 3.0  # return time at washout_speed_mps and above [s]
    washout_speed_mps: Positive = 25.0  # [m/s]
    roll_limit_rad: Positive = 0.12  # platform limits: the output is clamped to ± these
    pitch_limit_rad: Positive = 0.12
    heave_limit_m: Positive = 0.025


@dataclass(slots=True)
class MotionCue:
    """One platform command, as the FRAME_UPDATE carries it."""

    roll: float = 0.0  # [rad]
    pitch: float = 0.0  # [rad]
    heave: float = 0.0  # [m]
    rpm: float = 0.0  # [1/min]
    torque: float = 0.0  # [N·m] engine torque


class _Pulse:
    """A half-sine cue: 0 → peak → 0 over `duration_s`; smooth, so the rig never jerks."""

    __slots__ = ("duration_s", "elapsed_s", "heave", "pitch", "roll")

    def __init__(self, duration_s: float, heave: float, pitch: float, roll: float) -> None:
        self.duration_s, self.elapsed_s = duration_s, 0.0
        self.heave, self.pitch, self.roll = heave, pitch, roll

    def shape(self) -> float:
        return math.sin(math.pi * self.elapsed_s / self.duration_s)


class MotionCueing:
    """The MCA with its filter states. `update` once per loop tick."""

    def __init__(self, params: MotionCueingParams) -> None:
        self.params = params
        p = params
        self._ax = LowPass(p.accel_lpf_s)
        self._ay = LowPass(p.accel_lpf_s)
        self._az = LowPass(p.accel_lpf_s)
        self._brake, self._steer = LowPass(p.brake_lpf_s), LowPass(p.steer_lpf_s)
        self._jx, self._jz = LowPass(p.jerk_lpf_s), LowPass(p.jerk_lpf_s)
        self._road_pitch_slow: LowPass | None = None  # θ_road's low-pass, from its first value
        self._prev_ax = self._prev_az = self._prev_brake = 0.0
        self._armed = True
        self._pulses: list[_Pulse] = []
        self._out = [0.0, 0.0, 0.0]  # roll, pitch, heave after washout
        self._alpha_dt = -1.0
        self._attack = 1.0
        self.brake_rate = 0.0  # ḃ of the filtered pedal, last step [1/s]

    def collision(self, response: ImpulseResponse) -> None:
        """Queue a jolt: heave by |Δv|, pitch by forward Δv, roll by leftward Δv."""
        p = self.params
        self._add_pulse(
            _Pulse(
                p.collision_pulse_s,
                p.collision_heave_m_per_mps * response.magnitude(),
                p.collision_pitch_rad_per_mps * response.dvx_body,
                p.collision_roll_rad_per_mps * response.dvy_body,
            )
        )

    def update(
        self,
        dt: float,
        ax: float,
        ay: float,
        az: float,
        speed_mps: float,
        brake: float,
        steer: float,
        rpm: float = 0.0,
        torque_nm: float = 0.0,
        road_pitch_rad: float = 0.0,
    ) -> MotionCue:
        """ax, ay, az body-frame accelerations [m/s²] (az without gravity); pedals 0..1;
        road_pitch_rad the body's pitch over the road, nose up positive [rad]."""
        p = self.params
        ax_f, ay_f, az_f = self._ax.update(ax, dt), self._ay.update(ay, dt), self._az.update(az, dt)
        brake_f = self._brake.update(brake, dt)
        self.brake_rate = (brake_f - self._prev_brake) / dt
        self._prev_brake = brake_f
        self._check_emergency(brake)
        f_scale = smoothstep(p.scale_speed_start_mps, p.scale_speed_full_mps, abs(speed_mps))
        # The pedal terms cue a deceleration; a car at rest decelerates nothing, so they fade
        # out over the last scale_speed_start_mps and the washout takes the nose home.
        rolling = smoothstep(0.0, p.scale_speed_start_mps, abs(speed_mps))
        pitch = ax_f / p.a_ref_mps2_per_rad * f_scale
        pitch += rolling * (p.k_brake_rad * brake_f + p.k_brake_rate_rad_s * self.brake_rate)
        pitch += p.k_road_pitch * self._road_pitch_change(road_pitch_rad, dt)
        roll = ay_f / p.ay_ref_mps2_per_rad + p.k_steer_rad * self._steer.update(steer, dt)
        heave = p.k_jx_m_per_mps3 * self._jerk(self._jx, ax_f, self._prev_ax, dt)
        heave += p.k_jz_m_per_mps3 * self._jerk(self._jz, az_f, self._prev_az, dt)
        self._prev_ax, self._prev_az = ax_f, az_f
        roll, pitch, heave = self._apply_pulses(dt, roll, pitch, heave)
        self._washout(dt, abs(speed_mps), roll, pitch, heave)
        out = self._out
        return MotionCue(
            roll=clamp(out[0], -p.roll_limit_rad, p.roll_limit_rad),
            pitch=clamp(out[1], -p.pitch_limit_rad, p.pitch_limit_rad),
            heave=clamp(out[2], -p.heave_limit_m, p.heave_limit_m),
            rpm=rpm,
            torque=torque_nm,
        )

    def road_moved(self) -> None:
        """The road under the car changed at once (a new spawn, a new surface): take the
        attitude it gives as the rest, rather than cue the jump."""
        self._road_pitch_slow = None

    def _road_pitch_change(self, road_pitch: float, dt: float) -> float:
        """θ̃_road: the road pitch less its low-pass (a first-order high-pass) [rad]."""
        slow = self._road_pitch_slow
        if slow is None:  # the car starts where it stands: no cue for the attitude it has
            slow = self._road_pitch_slow = LowPass(self.params.road_pitch_washout_s, road_pitch)
        return road_pitch - slow.update(road_pitch, dt)

    def _jerk(self, lpf: LowPass, accel: float, previous: float, dt: float) -> float:
        """Conditioned jerk j̃: derivative → deadband → clamp → low-pass [m/s³]."""
        limit = self.params.jerk_clamp_mps3
        jerk = deadband((accel - previous) / dt, self.params.jerk_deadband_mps3)
        return lpf.update(clamp(jerk, -limit, limit), dt)

    def _check_emergency(self, brake: float) -> None:
        p = self.params
        if brake < p.emergency_brake_rearm_pedal:
            self._armed = True
        elif (
            self._armed
            and brake >= p.emergency_brake_pedal
            and self.brake_rate >= p.emergency_brake_rate_per_s
        ):
            self._armed = False
            self._add_pulse(_Pulse(p.emergency_heave_s, p.emergency_heave_m, 0.0, 0.0))

    def _add_pulse(self, pulse: _Pulse) -> None:
        if len(self._pulses) >= MAX_PULSES:
            self._pulses.pop(0)  # the oldest is nearly over; dropping it is a small dent
        self._pulses.append(pulse)

    def _apply_pulses(
        self, dt: float, roll: float, pitch: float, heave: float
    ) -> tuple[float, float, float]:
        if not self._pulses:
            return roll, pitch, heave
        alive = []
        for pulse in self._pulses:
            pulse.elapsed_s += dt
            if pulse.elapsed_s < pulse.duration_s:
                k = pulse.shape()
                roll += k * pulse.roll
                pitch += k * pulse.pitch
                heave += k * pulse.heave
                alive.append(pulse)
        self._pulses = alive
        return roll, pitch, heave

    def _washout(self, dt: float, speed: float, *cues: float) -> None:
        p = self.params
        share = smoothstep(0.0, p.washout_speed_mps, speed)
        time_s = p.washout_low_speed_s + share * (p.washout_high_speed_s - p.washout_low_speed_s)
        release = lpf_alpha(dt, time_s / 4.0)
        if dt != self._alpha_dt:
            self._alpha_dt, self._attack = dt, lpf_alpha(dt, p.attack_s)
        out = self._out
        for i, raw in enumerate(cues):
            # Growing away from neutral: attack; shrinking toward it: washout.
            k = self._attack if (raw - out[i]) * raw > 0.0 else release
            out[i] += (raw - out[i]) * k
