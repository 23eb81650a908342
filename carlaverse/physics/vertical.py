"""The car's vertical motion over the road profile: heave, pitch and the wheels' shake.

Model: a pitch-plane half-car as two independent quarter-cars, one per axle (exact when the
body's pitch inertia is m·a·b, the usual "dynamic index 1" simplification). Each carries its
share of the sprung mass on a spring k_s and damper c_s over an unsprung mass m_u on a tyre
spring k_t (no tyre damping), per kg of sprung mass (`params.Suspension`, the IRI's Golden
Car by default). Heights are from static equilibrium, so gravity drops out:

    z̈_s = k_s·(z_u − z_s) + c_s·(ż_u − ż_s)
    z̈_u = (k_t·(z_r − z_u) − k_s·(z_u − z_s) − c_s·(ż_u − ż_s)) / μ,   μ = m_u/m_s

integrated by semi-implicit Euler (stable while ω·h < 2; wheel hop ω ≈ 69 rad/s, h ≤ 5 ms).

z_r of an axle is the mean road height under its two wheels (track apart): the half-car has no
roll, so a pothole under one wheel lifts that axle half as much. Roughness is read at each
axle's path distance (the rear axle meets the front's profile a wheelbase later); features at
the wheels' map positions. Out of it:

- `heave_accel_mps2`: the body's vertical acceleration at the centre of gravity, (b·z̈_f +
  a·z̈_r)/L — the a_z the motion cueing's vertical-jerk term reads (paper, "Motion Cueing");
- `pitch_rad`: the body's pitch over the road, atan((z_s,front − z_s,rear)/L), nose up
  positive as in the motion packet;
- `wheel_accel_mps2`: the front unsprung mass's vertical acceleration, what reaches the
  steering wheel as road shake (steering_feel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.physics.params import Body, Suspension
from carlaverse.physics.road_surface import RoadProfile


class QuarterCar:
    """One axle: sprung and unsprung heights [m] and velocities [m/s] from equilibrium."""

    __slots__ = ("accel_s", "accel_u", "c", "k", "kt", "mu", "v_s", "v_u", "z_s", "z_u")

    def __init__(self, suspension: Suspension) -> None:
        self.k, self.c = suspension.spring_per_kg, suspension.damping_per_kg
        self.kt, self.mu = suspension.tyre_per_kg, suspension.unsprung_ratio
        self.z_s = self.v_s = self.z_u = self.v_u = 0.0
        self.accel_s = self.accel_u = 0.0  # [m/s²] of the last step

    def settle(self, z_road: float) -> None:
        """At rest on the road at z_road [m]: static equilibrium, no motion."""
        self.z_s = self.z_u = z_road
        self.v_s = self.v_u = self.accel_s = self.accel_u = 0.0

    def step(self, h: float, z_road: float) -> None:
        """Advance h [s] with the road at z_road [m] under the tyre."""
        suspension = self.k * (self.z_u - self.z_s) + self.c * (self.v_u - self.v_s)
        self.accel_s = suspension
        self.accel_u = (self.kt * (z_road - self.z_u) - suspension) / self.mu
        self.v_s += self.accel_s * h
        self.v_u += self.accel_u * h
        self.z_s += self.v_s * h
        self.z_u += self.v_u * h


@dataclass(frozen=True, slots=True)
class VerticalState:
    """One tick of the vertical model, for the loop's output."""

    road_front_m: float  # [m] road height under the front axle (mean of its wheels)
    road_rear_m: float  # [m]
    heave_m: float  # [m] body at the centre of gravity, up positive
    pitch_rad: float  # [rad] body, nose up positive
    heave_accel_mps2: float  # [m/s²] body at the centre of gravity, without gravity
    wheel_accel_mps2: float  # [m/s²] front unsprung mass


class VerticalDynamics:
    """Heave and pitch of the body and the front wheels' shake over a `RoadProfile`."""

    def __init__(self, body: Body, suspension: Suspension, profile: RoadProfile) -> None:
        self.profile = profile
        self.to_front_m = body.cg_to_front_axle_m
        self.to_rear_m = body.wheelbase_m - body.cg_to_front_axle_m
        self.wheelbase_m = body.wheelbase_m
        self.half_track_m = suspension.track_m / 2.0
        self.front, self.rear = QuarterCar(suspension), QuarterCar(suspension)
        self.distance_m = 0.0  # [m] the centre of gravity's path, signed (reversing counts down)
        self.road_front_m = self.road_rear_m = 0.0
        self._placed = False

    def step(self, h: float, x: float, y: float, yaw: float, speed_mps: float) -> None:
        """Advance h [s] with the centre of gravity at (x, y) [m], heading yaw [rad]."""
        self.distance_m += speed_mps * h
        c, s = math.cos(yaw), math.sin(yaw)
        front = self._axle_road(x + self.to_front_m * c, y + self.to_front_m * s, c, s,
                                self.distance_m + self.to_front_m)  # fmt: skip
        rear = self._axle_road(x - self.to_rear_m * c, y - self.to_rear_m * s, c, s,
                               self.distance_m - self.to_rear_m)  # fmt: skip
        if not self._placed:  # the first contact: start at rest on the road, not dropped on it
            self.front.settle(front)
            self.rear.settle(rear)
            self._placed = True
        self.road_front_m, self.road_rear_m = front, rear
        self.front.step(h, front)
        self.rear.step(h, rear)

    def place(self) -> None:
        """The car was put somewhere new: settle on the road there at the next step."""
        self._placed = False

    def _axle_road(self, x: float, y: float, c: float, s: float, distance_m: float) -> float:
        """Mean road height [m] under an axle's two wheels, the left one at +half track.
        Both wheels run the same roughness profile: one track, read once."""
        profile = self.profile
        z = profile.roughness_height(distance_m)
        if profile.has_features:
            ox, oy = -s * self.half_track_m, c * self.half_track_m
            z += 0.5 * (
                profile.feature_height(x + ox, y + oy) + profile.feature_height(x - ox, y - oy)
            )
        return z

    def state(self) -> VerticalState:
        """Heave, pitch and accelerations now."""
        f, r, L = self.front, self.rear, self.wheelbase_m
        a, b = self.to_front_m, self.to_rear_m
        return VerticalState(
            self.road_front_m,
            self.road_rear_m,
            (b * f.z_s + a * r.z_s) / L,
            math.atan2(f.z_s - r.z_s, L),
            (b * f.accel_s + a * r.accel_s) / L,
            f.accel_u,
        )
