"""Measuring a trainer's resistance table with a speed-ramp protocol.

For each resistance level r the protocol commands r, then has the roller driven through a
speed ramp v_min → v_max → v_min (a calibration rig's motor, or in the simulation the
`SimFtmsPeripheral.drive`). From every Indoor Bike Data sample it takes the force at
the tyre, F = P / v. While accelerating that force includes the flywheel's m·a, while
decelerating it lacks it: averaging the up- and the down-ramp at the same speed cancels the
inertia without knowing it, and their difference measures it: F_up − F_down = 2·m_eq·a. The
result F(v, r) is inverted per speed into the table the bike node reads: r(v, F) for the wanted
force grid (`ResistanceTable`). Beyond the brake's range the inversion extends its last
segment rather than stopping at 0 or 100 %: the table's reader clamps, and a force between a
column inside the range and one beyond it then still reads the right level. The table also
keeps F at 0 % and at 100 % per speed and m_eq: what the trainer can render at all.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated

import msgspec
import numpy as np

from carlaverse.config import StrictStruct
from carlaverse.hal.trainer.ftms import FtmsTrainer
from carlaverse.hal.trainer.resistance_table import ResistanceTable

Positive = Annotated[float, msgspec.Meta(gt=0)]
DriveSpeed = Callable[[float, float], None]  # roller speed [m/s] from now, ramping [m/s²]
Wait = Callable[[float], None]  # let this much device time [s] pass


class RampProtocol(StrictStruct):
    levels_percent: tuple[float, ...] = (0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100)
    speed_min_mps: Positive = 0.5
    speed_max_mps: Positive = 15.0
    ramp_s: Positive = 30.0  # [s] each way
    sample_s: Positive = 0.25  # [s] one reading per Indoor Bike Data notification
    settle_s: Positive = 2.0  # [s] at v_min after a level change
    # rows: half-metre steps where the brake's force bends most with speed (bilinear reading)
    speeds_mps: tuple[float, ...] = (1, 1.5, 2, 2.5, *range(3, 15))
    forces_n: tuple[float, ...] = (0, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 120, 150)  # cols


Samples = list[tuple[float, float]]  # (speed [m/s], force [N])


def ramp_level(
    trainer: FtmsTrainer, protocol: RampProtocol, level: float, drive: DriveSpeed, wait: Wait
) -> tuple[Samples, Samples]:
    """(up-ramp, down-ramp) samples at one resistance level."""
    trainer.set_resistance(level)
    low, high = protocol.speed_min_mps, protocol.speed_max_mps
    rate = (high - low) / protocol.ramp_s  # [m/s²]
    drive(low, 0.0)
    wait(protocol.settle_s)
    ramps: tuple[Samples, Samples] = ([], [])
    for ramp, start, accel in ((ramps[0], low, rate), (ramps[1], high, -rate)):
        drive(start, accel)
        for _ in range(round(protocol.ramp_s / protocol.sample_s)):
            wait(protocol.sample_s)
            trainer.read()  # lets a link without its own thread deliver
            data = trainer.latest  # signed power: a braking rig reads negative
            if data.speed_kmh and data.speed_kmh > 0.36 and data.power_w is not None:
                speed = data.speed_kmh / 3.6
                ramp.append((speed, data.power_w / speed))
    return ramps


def force_at(samples: Samples, speeds: tuple[float, ...]) -> np.ndarray:
    """Forces interpolated at `speeds` from samples sorted by speed."""
    pts = sorted(samples)
    return np.interp(speeds, [v for v, _ in pts], [f for _, f in pts])


def invert(
    protocol: RampProtocol, forces: np.ndarray, trainer_name: str, mass_eq_kg: float = 0.0
) -> ResistanceTable:
    """forces[k, i] = F at level k and speed i  →  percent[i][j] for forces_n[j]."""
    levels = np.asarray(protocol.levels_percent, dtype=float)
    rows = []
    for i in range(len(protocol.speeds_mps)):
        column = np.maximum.accumulate(forces[:, i])  # force never falls as r rises
        rows.append([round(_level_at(f, column, levels), 3) for f in protocol.forces_n])
    return ResistanceTable(
        speeds_mps=list(protocol.speeds_mps),
        forces_n=list(protocol.forces_n),
        resistance_percent=rows,
        trainer=trainer_name,
        force_min_n=[round(float(f), 3) for f in forces[0]],
        force_max_n=[round(float(f), 3) for f in forces[-1]],
        flywheel_mass_eq_kg=round(mass_eq_kg, 3),
    )


def _level_at(force: float, column: np.ndarray, levels: np.ndarray) -> float:
    """The level giving `force`, linear between measured levels and along the end segments
    beyond them (np.interp would hold the end value)."""
    end = 0 if force < column[0] else len(column) - 2 if force > column[-1] else None
    if end is None:
        return float(np.interp(force, column, levels))
    span = column[end + 1] - column[end]
    if span <= 0:  # a flat end: no slope to extend
        return float(levels[0] if end == 0 else levels[-1])
    return float(levels[end] + (force - column[end]) * (levels[end + 1] - levels[end]) / span)


def calibrate(
    trainer: FtmsTrainer, protocol: RampProtocol, drive: DriveSpeed, wait: Wait, name: str = ""
) -> ResistanceTable:
    """Run the whole protocol and return the measured table."""
    per_level, inertia = [], []
    rate = (protocol.speed_max_mps - protocol.speed_min_mps) / protocol.ramp_s  # [m/s²]
    for level in protocol.levels_percent:
        up, down = ramp_level(trainer, protocol, level, drive, wait)
        speeds = protocol.speeds_mps
        f_up, f_down = force_at(up, speeds), force_at(down, speeds)
        per_level.append((f_up + f_down) / 2)
        inertia.append((f_up - f_down) / (2 * rate))  # m_eq at each speed
    drive(0.0, 0.0)
    return invert(protocol, np.array(per_level), name, float(np.median(inertia)))
