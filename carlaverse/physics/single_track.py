"""Dynamic single-track (bicycle) model with longitudinal load transfer.

State in the body frame (x forward, y left, z up) at the centre of gravity: forward speed vx,
lateral speed vy, yaw rate r; pose (x, y, yaw) in the world frame. Each axle carries a
magic-formula tyre on its share of the load, F_z front/rear = static ± m·a_x·h/L, with a_x
lagged through a 20 ms filter — roughly the suspension's pitch response, and it keeps the
load ↔ brake-limit loop from ringing.

Longitudinal forces that oppose motion (brakes, rolling resistance) are Coulomb friction:
they can stop the car and then hold it, but never push it backwards — a stopped car stays
exactly stopped. Lateral stability at v ≈ 0 comes from the regularised slip angle (tyre.py).

Integration: explicit Euler at the loop rate. The stiffest mode is the tyre's lateral damping
at standstill, λ ≈ C_α/(m·v_min) ≈ 150 1/s for the shipped cars, so λ·dt ≈ 0.15 at 1 kHz
(stable for dt < 2/λ ≈ 13 ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.physics.filters import lpf_alpha
from carlaverse.physics.params import Body, Tyres
from carlaverse.physics.tyre import friction_ellipse_scale, lateral_force, slip_angle

G = 9.81  # [m/s²]
LOAD_TRANSFER_TAU_S = 0.02  # [s] lag of the load transfer behind a_x
# ABS keeps a braking tyre below its peak slip, so it stays steerable; the friction ellipse
# is therefore evaluated with at most this share of the grip in use longitudinally.
ABS_MAX_LONGITUDINAL_SHARE = 0.85
MIN_AXLE_LOAD_SHARE = 0.05  # an axle never fully unloads in this model (no wheelies) [-]


@dataclass(slots=True)
class ChassisState:
    x: float = 0.0  # [m] world
    y: float = 0.0  # [m] world
    yaw: float = 0.0  # [rad] world, counter-clockwise from +x
    vx: float = 0.0  # [m/s] body, forward
    vy: float = 0.0  # [m/s] body, left
    yaw_rate: float = 0.0  # [rad/s]
    ax: float = 0.0  # [m/s²] body-frame acceleration of the CG, from the forces
    ay: float = 0.0  # [m/s²]
    fz_front: float = 0.0  # [N] axle loads
    fz_rear: float = 0.0  # [N]
    alpha_front: float = 0.0  # [rad] slip angles
    alpha_rear: float = 0.0  # [rad]
    steer: float = 0.0  # [rad] road-wheel angle

    def speed(self) -> float:
        return math.hypot(self.vx, self.vy)


class SingleTrack:
    """Chassis + tyres. Forces in, motion out; the powertrain and brakes live in `car.py`."""

    def __init__(self, body: Body, tyres: Tyres, brake_front_bias: float = 0.65) -> None:
        self.body = body
        self.tyres = tyres
        self.brake_front_bias = brake_front_bias  # share of brake force on the front axle
        self.mass = body.mass_kg
        self.a = body.cg_to_front_axle_m  # CG to front axle [m]
        self.b = body.wheelbase_m - body.cg_to_front_axle_m  # CG to rear axle [m]
        self._drag = 0.5 * body.air_density_kgm3 * body.drag_area_m2  # [kg/m]
        self._roll = body.rolling_resistance * self.mass * G  # [N]
        self._transfer = self.mass * body.cg_height_m / body.wheelbase_m  # [kg]
        self._ax_load = 0.0  # lagged a_x for the load transfer [m/s²]
        self._alpha_dt = -1.0
        self._alpha = 1.0
        self.state = ChassisState()
        self._update_loads()

    def axle_loads(self) -> tuple[float, float]:
        """Vertical loads front, rear [N] for the current (lagged) longitudinal acceleration."""
        static = self.mass * G / (self.a + self.b)
        shift = self._transfer * self._ax_load
        floor = MIN_AXLE_LOAD_SHARE * self.mass * G
        return max(static * self.b - shift, floor), max(static * self.a + shift, floor)

    def _update_loads(self) -> None:
        self.state.fz_front, self.state.fz_rear = self.axle_loads()

    def step(
        self,
        dt: float,
        steer_rad: float,
        drive_front_n: float,
        drive_rear_n: float,
        brake_n: float,
        extra_mass_kg: float = 0.0,
        mu_scale: float = 1.0,
    ) -> None:
        """Advance dt [s] under drive forces (signed, + forward) and brake force [N] (≥ 0).

        extra_mass_kg: rotating inertia reflected to the wheels (adds to longitudinal only).
        mu_scale: road friction relative to dry asphalt (wet ≈ 0.7, snow ≈ 0.3).
        """
        s = self.state
        mu = self.tyres.mu * mu_scale
        fzf, fzr = s.fz_front, s.fz_rear
        drive_front_n = _limit(drive_front_n, mu * fzf)
        drive_rear_n = _limit(drive_rear_n, mu * fzr)
        brake_front, brake_rear = self._brake_split(brake_n, mu, fzf, fzr)
        cos_d, sin_d = math.cos(steer_rad), math.sin(steer_rad)
        fyf, fyr = self._lateral_forces(
            s, mu, cos_d, sin_d, abs(drive_front_n) + brake_front, abs(drive_rear_n) + brake_rear
        )
        # Front tyre force resolved into the body frame (brakes taken along the body x axis;
        # the sin δ part of a braking force is below the model's other simplifications).
        fy_front_body = fyf * cos_d + drive_front_n * sin_d
        propulsive = drive_front_n * cos_d - fyf * sin_d + drive_rear_n
        vx_old = s.vx
        self._longitudinal(dt, propulsive, brake_front + brake_rear, extra_mass_kg)
        self._lateral(dt, vx_old, fy_front_body, fyr)
        s.steer = steer_rad
        self._integrate_pose(dt)
        self._lag_load_transfer(dt)

    def _longitudinal(self, dt: float, propulsive: float, brake: float, extra_mass: float) -> None:
        """vx under tyre forces, drag and the Coulomb resistances; a_x from the change."""
        s = self.state
        propulsive -= self._drag * s.vx * abs(s.vx)
        propulsive += self.mass * s.vy * s.yaw_rate  # body-frame rotation: v̇x = F_x/m + vy·r
        vx_old = s.vx
        s.vx = _coulomb(vx_old, propulsive, brake + self._roll, self.mass + extra_mass, dt)
        s.ax = (s.vx - vx_old) / dt - s.vy * s.yaw_rate

    def _lateral(self, dt: float, vx_old: float, fy_front_body: float, fy_rear: float) -> None:
        """vy and yaw rate, explicit Euler with the start-of-step forward speed."""
        s = self.state
        s.ay = (fy_front_body + fy_rear) / self.mass
        yaw_acc = (self.a * fy_front_body - self.b * fy_rear) / self.body.yaw_inertia_kgm2
        s.vy += (s.ay - vx_old * s.yaw_rate) * dt
        s.yaw_rate += yaw_acc * dt

    def _brake_split(
        self, brake_n: float, mu: float, fzf: float, fzr: float
    ) -> tuple[float, float]:
        """Brake force per axle with ideal ABS: never more than the axle's grip [N]."""
        bias = self.brake_front_bias
        return min(brake_n * bias, mu * fzf), min(brake_n * (1.0 - bias), mu * fzr)

    def _lateral_forces(
        self, s: ChassisState, mu: float, cos_d: float, sin_d: float, fx_front: float,
        fx_rear: float,
    ) -> tuple[float, float]:  # fmt: skip
        tyres, v_min = self.tyres, self.tyres.slip_speed_min_mps
        vy_front = s.vy + self.a * s.yaw_rate
        v_long = s.vx * cos_d + vy_front * sin_d
        v_lat = -s.vx * sin_d + vy_front * cos_d
        s.alpha_front = slip_angle(v_long, v_lat, v_min)
        s.alpha_rear = slip_angle(s.vx, s.vy - self.b * s.yaw_rate, v_min)
        fzf, fzr = s.fz_front, s.fz_rear
        fyf = lateral_force(s.alpha_front, fzf, mu, tyres.stiffness_b_front, tyres.shape_c)
        fyr = lateral_force(s.alpha_rear, fzr, mu, tyres.stiffness_b_rear, tyres.shape_c)
        cap = ABS_MAX_LONGITUDINAL_SHARE
        fyf *= friction_ellipse_scale(min(abs(fx_front), cap * mu * fzf), fzf, mu)
        fyr *= friction_ellipse_scale(min(abs(fx_rear), cap * mu * fzr), fzr, mu)
        return fyf, fyr

    def _integrate_pose(self, dt: float) -> None:
        s = self.state
        c, si = math.cos(s.yaw), math.sin(s.yaw)
        s.x += (s.vx * c - s.vy * si) * dt
        s.y += (s.vx * si + s.vy * c) * dt
        s.yaw += s.yaw_rate * dt
        if s.yaw > math.pi:
            s.yaw -= 2.0 * math.pi
        elif s.yaw < -math.pi:
            s.yaw += 2.0 * math.pi

    def _lag_load_transfer(self, dt: float) -> None:
        if dt != self._alpha_dt:
            self._alpha_dt, self._alpha = dt, lpf_alpha(dt, LOAD_TRANSFER_TAU_S)
        self._ax_load += (self.state.ax - self._ax_load) * self._alpha
        self._update_loads()


def _limit(force: float, limit: float) -> float:
    return limit if force > limit else -limit if force < -limit else force


def _coulomb(v: float, propulsive: float, friction: float, mass: float, dt: float) -> float:
    """New speed under a propulsive force and a friction force that only ever opposes motion.

    A moving body decelerates and stops exactly at 0 instead of overshooting; a stopped body
    starts only when the propulsive force exceeds the friction that holds it.
    """
    if v > 0.0:
        v += (propulsive - friction) / mass * dt
        return v if v > 0.0 else 0.0
    if v < 0.0:
        v += (propulsive + friction) / mass * dt
        return v if v < 0.0 else 0.0
    if propulsive > friction:
        return (propulsive - friction) / mass * dt
    if propulsive < -friction:
        return (propulsive + friction) / mass * dt
    return 0.0
