"""What the trainer is told: the road's resistance, the rider's missing inertia, and what the
trainer cannot render.

On the road the rider's pedalling moves bike and rider, mass m; on the trainer it moves only
the flywheel, m_eq at the tyre (12 kg for the simulated trainer against 90 kg):

    road:     P/v − F_res = m·a          trainer:  P/v − F_brake = m_eq·a

Both give the rider the same acceleration a when the brake adds the mass the flywheel lacks,

    F_brake = F_res + (m − m_eq)·a

so the brake works harder while the rider speeds up and eases off while they slow down. m_eq is
measured by the calibration (`ResistanceTable.flywheel_mass_eq_kg`). a is the wheel's, smoothed
over `accel_tau_s`; that smoothing keeps the loop stable. The brake's force acts back on the
acceleration it is computed from, (m − m_eq)/m_eq = 6.5 times over, through the trainer's
delays (speed reported and level written at 4 Hz): with 0.5 s the simulated rider's speed
oscillated, 1 s was stable, 1.5 s leaves margin. The price is lag: at 250 W from 5.5 to
7.5 m/s the rider takes 9.8 s against the road's 8.0 s (1.0 s on the bare flywheel).

A brake only resists, between its own drag at 0 % and its force at 100 % at this speed (the
table's `force_range`). Outside that the command is clipped and the limit named:

- `too_steep`: more than 100 % gives (a 10 % climb at 3 m/s needs 94 N; the simulated trainer
  gives 67 N);
- `cannot_push`: the road pushes the bike (a descent, a strong tailwind): a brake cannot push;
- `too_light`: slowing down, the flywheel's own drag is more than the road and the missing
  mass leave (coasting from 10 to 5 m/s takes the bike 25.7 s, the bare simulated flywheel
  6.1 s, and 3.4 s if the brake rendered only the road's force).

The loop counts the seconds in each, and the node's summary and the HMI report them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Annotated, Any

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.trainer.resistance_table import ResistanceTable

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class TrainerFeelParams(StrictStruct):
    """The `trainer_feel:` section of a bike config."""

    inertia: bool = True  # add the mass the flywheel lacks through the brake
    accel_tau_s: Positive = 1.5  # [s] smoothing of the wheel's acceleration (stability)
    tolerance_n: NonNegative = 1.0  # [N] a shortfall smaller than this is not a limit


class TrainerLimit(enum.IntEnum):
    NONE = 0
    TOO_STEEP = 1
    CANNOT_PUSH = 2
    TOO_LIGHT = 3


@dataclass(frozen=True, slots=True)
class TrainerTarget:
    percent: float  # [%] the resistance level to command
    wanted_n: float  # [N] F_res plus the missing inertia: what the rider should feel
    missing_n: float  # [N] wanted minus what the brake gives: > 0 too light, < 0 too heavy
    limit: TrainerLimit


class TrainerCommand:
    """Turns the road's force into the trainer's level, once per loop tick."""

    def __init__(self, table: ResistanceTable, rider_mass_kg: float,
                 params: TrainerFeelParams) -> None:  # fmt: skip
        self.table, self.params = table, params
        m_eq = table.flywheel_mass_eq_kg
        self.extra_mass_kg = max(0.0, rider_mass_kg - m_eq) if params.inertia and m_eq else 0.0
        self.rider_mass_kg = rider_mass_kg
        self._speed_smooth: float | None = None  # [m/s] the wheel speed, low-passed
        self.accel_mps2 = 0.0  # [m/s²] the wheel's smoothed acceleration
        self.seconds = dict.fromkeys(TrainerLimit, 0.0)
        self.worst_missing_n = dict.fromkeys(TrainerLimit, 0.0)

    def update(self, dt: float, speed_mps: float, road_force_n: float) -> TrainerTarget:
        """The level for the wheel at `speed_mps` on a road resisting with `road_force_n`."""
        smooth = speed_mps if self._speed_smooth is None else self._speed_smooth  # first: a = 0
        self.accel_mps2 = (speed_mps - smooth) / self.params.accel_tau_s
        self._speed_smooth = smooth + self.accel_mps2 * dt
        wanted = road_force_n + self.extra_mass_kg * self.accel_mps2
        given, limit = self._renderable(speed_mps, wanted, road_force_n)
        missing = wanted - given
        self.seconds[limit] += dt
        if abs(missing) > abs(self.worst_missing_n[limit]):
            self.worst_missing_n[limit] = missing
        level = {TrainerLimit.TOO_STEEP: 100.0, TrainerLimit.NONE: None}.get(limit, 0.0)
        if level is None:  # within reach: the table (it clamps to 0..100 itself)
            level = self.table.percent(speed_mps, wanted)
        return TrainerTarget(level, wanted, missing, limit)

    def _renderable(self, speed_mps: float, wanted: float,
                    road_force_n: float) -> tuple[float, TrainerLimit]:  # fmt: skip
        span = self.table.force_range(speed_mps)
        if span is None:  # a table without the measured range: nothing to judge by
            return wanted, TrainerLimit.NONE
        low, high = span
        slack = self.params.tolerance_n
        if wanted > high + slack:
            return high, TrainerLimit.TOO_STEEP
        if wanted < low - slack:
            return low, TrainerLimit.CANNOT_PUSH if road_force_n < 0 else TrainerLimit.TOO_LIGHT
        return min(max(wanted, low), high), TrainerLimit.NONE

    def summary(self) -> dict[str, Any]:
        """What the trainer could not render, for the node's summary."""
        out: dict[str, Any] = {
            "rider_mass_kg": self.rider_mass_kg,
            "flywheel_mass_eq_kg": self.table.flywheel_mass_eq_kg or None,
            "inertia_added_kg": round(self.extra_mass_kg, 2),
            "range_known": self.table.force_range(0.0) is not None,
        }
        for limit in list(TrainerLimit)[1:]:
            name = limit.name.lower()
            out[f"{name}_s"] = round(self.seconds[limit], 2)
            out[f"{name}_worst_n"] = round(self.worst_missing_n[limit], 1)
        return out
