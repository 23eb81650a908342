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

A smart trainer takes no newtons: the bike node turns F_res into a resistance level through the
trainer's calibrated table (`carlaverse.hal.trainer.resistance_table`).
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
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
