"""A smart trainer's calibrated resistance table: which level [%] makes it resist a force.

A smart trainer takes no newtons: `ResistanceTable` is the calibrated 2D table
(speed × force → resistance %) measured by `carlaverse calibrate trainer`
(`ftms_calibration`), read by bilinear interpolation and clamped at its edges. The calibration
also records what the trainer can render at all: its force at 0 % and at 100 % per speed (a
brake only resists, between its own drag and its strongest setting) and its flywheel's inertia
at the tyre. It belongs to the trainer, not to the bike's physics: the bike node computes the
force it wants (`carlaverse.physics.resistance`) and asks this table for the level.
"""

from __future__ import annotations

import bisect
import itertools
from pathlib import Path
from typing import Annotated

import msgspec
import yaml

from carlaverse.config import StrictStruct, load_config

NonNegative = Annotated[float, msgspec.Meta(ge=0)]


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
