"""Reference motions with bounded jerk, as exact functions of time (the benchmark's truth).

A remote-actor renderer is judged by how far its drawing is from where the actor truly is, so
the truth must be known at any instant and be physically plausible: position, velocity and
acceleration continuous, jerk bounded (no velocity steps, which no dead reckoning can foresee
and no vehicle performs). Each motion is computed once on a 1 ms grid — from a speed profile
and a curvature profile along the arc (clothoid transitions, as roads are built) or directly
— with velocity and acceleration by central differences; `at(t)` interpolates the grid
linearly (error ≤ a·dt²/8 ≈ 1 µm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carlaverse.messages import Pose
from carlaverse.support.angles import wrap_angle

GRID_S = 0.001  # [s]


@dataclass(frozen=True)
class Trajectory:
    name: str
    t: np.ndarray  # [s] grid
    x: np.ndarray  # [m]
    y: np.ndarray

    def __post_init__(self) -> None:
        vx, vy = np.gradient(self.x, GRID_S), np.gradient(self.y, GRID_S)
        object.__setattr__(self, "_v", (vx, vy))
        object.__setattr__(self, "_a", (np.gradient(vx, GRID_S), np.gradient(vy, GRID_S)))
        yaw = np.unwrap(np.arctan2(vy, vx))
        object.__setattr__(self, "_yaw", (yaw, np.gradient(yaw, GRID_S)))

    def _lerp(self, column: np.ndarray, t: float) -> float:
        return float(np.interp(t, self.t, column))

    def xy(self, t: float) -> tuple[float, float]:
        return self._lerp(self.x, t), self._lerp(self.y, t)

    def pose_at(self, t: float, seq: int = 0) -> Pose:
        """The sample a sender would publish at `t`: position, velocity, acceleration, yaw."""
        vx, vy = self._v  # type: ignore[attr-defined]
        ax, ay = self._a  # type: ignore[attr-defined]
        yaw, yaw_rate = self._yaw  # type: ignore[attr-defined]
        f = self._lerp
        return Pose(
            seq, t, f(self.x, t), f(self.y, t), yaw=wrap_angle(f(yaw, t)),
            vx=f(vx, t), vy=f(vy, t), wz=f(yaw_rate, t), ax=f(ax, t), ay=f(ay, t),
        )  # fmt: skip


def _grid(duration_s: float) -> np.ndarray:
    return np.arange(0.0, duration_s + GRID_S / 2, GRID_S)


def circle(duration_s: float, speed_mps: float = 14.0, radius_m: float = 20.0) -> Trajectory:
    t = _grid(duration_s)
    th = speed_mps / radius_m * t
    return Trajectory("circle", t, radius_m * np.cos(th), radius_m * np.sin(th))


def lane_change(duration_s: float, speed_mps: float = 14.0, width_m: float = 3.5,
                change_s: float = 3.0, hold_s: float = 2.0) -> Trajectory:  # fmt: skip
    """Straight on, changing lane left and back with minimum-jerk (quintic) lateral motion."""
    t = _grid(duration_s)
    period = 2 * (change_s + hold_s)
    phase = np.mod(t, period)
    up = np.clip(phase / change_s, 0.0, 1.0)
    down = np.clip((phase - change_s - hold_s) / change_s, 0.0, 1.0)
    smooth = lambda s: s**3 * (10 - 15 * s + 6 * s**2)  # noqa: E731 — minimum-jerk step
    return Trajectory("lane change", t, speed_mps * t, width_m * (smooth(up) - smooth(down)))


def rounded_rectangle(
    duration_s: float, speed_mps: float = 14.0, side_m: float = 60.0, radius_m: float = 20.0,
    transition_m: float = 12.0,
) -> Trajectory:  # fmt: skip
    """Straights joined by quarter turns entered and left along clothoids (curvature ramps
    linearly over `transition_m`), driven at constant speed."""
    t = _grid(duration_s)
    s = speed_mps * t
    k = 1.0 / radius_m
    # one side: straight, ramp up, arc, ramp down; the arc completes a quarter turn overall
    arc_m = radius_m * math.pi / 2 - transition_m
    lengths = np.array([side_m, transition_m, arc_m, transition_m])
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    u = np.mod(s, edges[-1])
    curvature = np.select(
        [u < edges[1], u < edges[2], u < edges[3]],
        [np.zeros_like(u), k * (u - edges[1]) / transition_m, np.full_like(u, k)],
        k * (1 - (u - edges[3]) / transition_m),
    )
    ds = speed_mps * GRID_S
    heading = np.concatenate([[0.0], np.cumsum((curvature[1:] + curvature[:-1]) / 2 * ds)])
    x = np.concatenate([[0.0], np.cumsum(np.cos(heading[:-1] + np.diff(heading) / 2) * ds)])
    y = np.concatenate([[0.0], np.cumsum(np.sin(heading[:-1] + np.diff(heading) / 2) * ds)])
    return Trajectory("rounded rectangle", t, x, y)


def stop_and_go(duration_s: float, top_speed_mps: float = 14.0, period_s: float = 12.0,
                ) -> Trajectory:  # fmt: skip
    """Along a straight, speed rising from standstill to top speed and back: v(t) =
    v_top (1 − cos 2πt/T) / 2, so acceleration and jerk are bounded (≤ 3.7 m/s², 1.9 m/s³)."""
    t = _grid(duration_s)
    w = 2 * math.pi / period_s
    x = top_speed_mps / 2 * (t - np.sin(w * t) / w)
    return Trajectory("stop-and-go", t, x, np.zeros_like(t))


PATHS = {"circle": circle, "lane change": lane_change, "rounded rectangle": rounded_rectangle,
         "stop-and-go": stop_and_go}  # fmt: skip
