"""Measuring a trainer's resistance table with a speed-ramp protocol.

For each resistance level r the protocol commands r, then has the roller driven through a
speed ramp v_min → v_max → v_min (a calibration rig's motor, or in the simulation the
`SimFtmsPeripheral.drive`). From every Indoor Bike Data sample it takes the force at
the tyre, F = P / v. While accelerating that force includes the flywheel's m·a, while
decelerating it lacks it: averaging the up- and the down-ramp at the same speed cancels the
inertia without knowing it. The result F(v, r) is inverted per speed into the table the bike
node reads: r(v, F) for the wanted force grid (`ResistanceTable`), clamped to 0..100 %.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated

import msgspec
import numpy as np

from carlaverse.config import StrictStruct
from carlaverse.hal.trainer.ftms import FtmsTrainer
from carlaverse.physics.resistance import ResistanceTable

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
    speeds_mps: tuple[float, ...] = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14)  # rows
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


def invert(protocol: RampProtocol, forces: np.ndarray, trainer_name: str) -> ResistanceTable:
    """forces[k, i] = F at level k and speed i  →  percent[i][j] for forces_n[j]."""
    levels = np.asarray(protocol.levels_percent, dtype=float)
    rows = []
    for i in range(len(protocol.speeds_mps)):
        column = np.maximum.accumulate(forces[:, i])  # force never falls as r rises
        rows.append([round(float(np.interp(f, column, levels)), 3) for f in protocol.forces_n])
    return ResistanceTable(
        speeds_mps=list(protocol.speeds_mps),
        forces_n=list(protocol.forces_n),
        resistance_percent=rows,
        trainer=trainer_name,
    )


def calibrate(
    trainer: FtmsTrainer, protocol: RampProtocol, drive: DriveSpeed, wait: Wait, name: str = ""
) -> ResistanceTable:
    """Run the whole protocol and return the measured table."""
    per_level = []
    for level in protocol.levels_percent:
        up, down = ramp_level(trainer, protocol, level, drive, wait)
        speeds = protocol.speeds_mps
        per_level.append((force_at(up, speeds) + force_at(down, speeds)) / 2)
    drive(0.0, 0.0)
    return invert(protocol, np.array(per_level), name)
