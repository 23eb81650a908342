"""Riding resistance of a bicycle and its translation into a trainer's resistance command.

The paper's equation (CycloCARLA, "Propulsion and Resistance"):

    F_res = f_R·m·g·cos θ  +  m·g·sin θ  +  ½·ρ·c_W·A·(v_bike − v_wind)²
            rolling           slope         aerodynamic drag

θ is the road's slope angle (grade g% → θ = atan(g/100)); v_wind is the wind's component
along the direction of travel, positive for a tailwind. The drag keeps the sign of the
relative air speed (a tailwind stronger than the bike pushes it), which equals the paper's
square whenever the bike is faster than the tailwind.

Wind comes from the authority's `Weather`: `wind_direction_deg` is where the wind blows FROM as
a compass bearing (0 north, 90 east, clockwise), as weather reports give it and as the sun's
azimuth in the same message is given.

A smart trainer takes no newtons: `ResistanceTable` is the calibrated 2D table
(speed × force → resistance %) measured by `carlaverse calibrate trainer`, read by bilinear
interpolation and clamped at its edges. The calibration also records what the trainer can
render at all: its force at 0 % and at 100 % per speed (a brake only resists, between its own
drag and its strongest setting) and its flywheel's inertia at the tyre.
"""

from __future__ import annotations

import bisect
import itertools
import math
from pathlib import Path
from typing import Annotated

import msgspec
import yaml

from carlaverse.config import StrictStruct, load_config
from carlaverse.physics.bicycle import G_MPS2

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class ResistanceParams(StrictStruct):
    rolling_coefficient: NonNegative = 0.004  # f_R [-], road tyre on asphalt
    drag_coefficient: NonNegative = 0.9  # c_W [-], upright city rider
    frontal_area_m2: NonNegative = 0.5  # A [m²]
    air_density_kgm3: Positive = 1.2  # ρ [kg/m³]


def slope_angle(grade_percent: float) -> float:
    """θ [rad] of a road rising `grade_percent` metres per 100 m."""
    return math.atan(grade_percent / 100.0)


def tailwind(wind_speed_mps: float, wind_from_deg: float, heading_rad: float) -> float:
    """Wind along the heading [m/s], positive from behind, for a wind blowing FROM that bearing.

    A wind from bearing β blows along −(sin β, cos β) in the world frame (x east, y north); its
    component on the heading (cos ψ, sin ψ) is −v·sin(β + ψ).
    """
    return -wind_speed_mps * math.sin(math.radians(wind_from_deg) + heading_rad)


def resistance_force(
    params: ResistanceParams, mass_kg: float, speed_mps: float, grade_percent: float,
    tailwind_mps: float = 0.0,
) -> float:  # fmt: skip
    """F_res [N] opposing the bike at `speed_mps` on the grade, with the wind along it."""
    theta = slope_angle(grade_percent)
    rolling = params.rolling_coefficient * mass_kg * G_MPS2 * math.cos(theta)
    slope = mass_kg * G_MPS2 * math.sin(theta)
    air = speed_mps - tailwind_mps  # [m/s] relative air speed
    drag = 0.5 * params.air_density_kgm3 * params.drag_coefficient * params.frontal_area_m2
    return rolling + slope + drag * air * abs(air)


class ResistanceTable(StrictStruct):
    """resistance_percent[i][j] is the command that makes the trainer resist forces_n[j]
    at speeds_mps[i]; both axes strictly increasing."""

    speeds_mps: Annotated[list[float], msgspec.Meta(min_length=2)]
    forces_n: Annotated[list[float], msgspec.Meta(min_length=2)]
    resistance_percent: list[list[float]]
    trainer: str = ""  # what was calibrated, for the record
    # Measured by the calibration, one per speed; empty in a table written by hand.
    force_min_n: list[float] = []  # [N] the trainer's force at 0 %: its own drag
    force_max_n: list[float] = []  # [N] its force at 100 %
    flywheel_mass_eq_kg: NonNegative = 0.0  # the flywheel's inertia at the tyre; 0: unknown

    def __post_init__(self) -> None:
        for name in ("speeds_mps", "forces_n"):
            axis = getattr(self, name)
            if any(b <= a for a, b in itertools.pairwise(axis)):
                raise ValueError(f"{name} must be strictly increasing, got {axis}")
        rows = self.resistance_percent
        if len(rows) != len(self.speeds_mps) or any(len(r) != len(self.forces_n) for r in rows):
            raise ValueError(
                f"resistance_percent must be {len(self.speeds_mps)} rows × "
                f"{len(self.forces_n)} columns (speeds × forces)"
            )
        for name in ("force_min_n", "force_max_n"):
            if len(getattr(self, name)) not in (0, len(self.speeds_mps)):
                raise ValueError(f"{name} must be empty or one per speed ({len(self.speeds_mps)})")

    def percent(self, speed_mps: float, force_n: float) -> float:
        """The trainer command [%] for `force_n` at `speed_mps`, bilinear, clamped to 0..100."""
        i, u = _cell(self.speeds_mps, speed_mps)
        j, w = _cell(self.forces_n, force_n)
        r = self.resistance_percent
        low = r[i][j] * (1 - w) + r[i][j + 1] * w
        high = r[i + 1][j] * (1 - w) + r[i + 1][j + 1] * w
        return max(0.0, min(100.0, low * (1 - u) + high * u))

    def force_range(self, speed_mps: float) -> tuple[float, float] | None:
        """(least, most) force [N] the trainer renders at `speed_mps`; None if not measured."""
        if not self.force_min_n or not self.force_max_n:
            return None
        i, u = _cell(self.speeds_mps, speed_mps)
        low, high = self.force_min_n, self.force_max_n
        return low[i] + (low[i + 1] - low[i]) * u, high[i] + (high[i + 1] - high[i]) * u

    def save(self, path: Path) -> None:
        path.write_text(yaml.safe_dump(msgspec.to_builtins(self), sort_keys=False))


def _cell(axis: list[float], value: float) -> tuple[int, float]:
    """Index of the cell holding `value` and the fraction across it (clamped at the ends)."""
    value = min(max(value, axis[0]), axis[-1])
    i = min(bisect.bisect_right(axis, value) - 1, len(axis) - 2)
    return i, (value - axis[i]) / (axis[i + 1] - axis[i])


def load_table(path: str | Path) -> ResistanceTable:
    """Load a calibrated table; a ConfigError names the file and the bad field."""
    return load_config(path, ResistanceTable)
