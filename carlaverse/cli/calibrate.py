"""`carlaverse calibrate trainer`: measure a trainer's resistance table and write it as YAML.

Against the simulated FTMS trainer (`--backend ftms_sim`, the default) the protocol runs on
the simulation's own clock, so the 11 ramps take seconds, not minutes. A real trainer needs a
rig that drives its roller at a commanded speed; that rig is not built yet, so a hardware
backend is refused with that reason rather than half-measured.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from carlaverse.cli.common import fail
from carlaverse.hal.trainer import ftms_sim
from carlaverse.hal.trainer.ftms_calibration import RampProtocol, calibrate


class ManualClock:
    """Seconds that pass only when the protocol waits."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    def advance(self, seconds: float) -> None:
        self.t += seconds


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("device", choices=["trainer"], help="what to calibrate")
    parser.add_argument("--backend", default="ftms_sim", help="trainer backend (ftms_sim)")
    parser.add_argument("--out", "-o", type=Path, default=Path("trainer-table.yaml"))
    parser.add_argument("--ramp-s", type=float, default=30.0, help="seconds per ramp, each way")
    parser.add_argument("--seed", type=int, default=0)


def run(args: argparse.Namespace) -> int:
    if args.backend != "ftms_sim":
        return fail(
            "calibrate",
            f"--backend {args.backend!r}: only 'ftms_sim' can be calibrated here; a real "
            "trainer needs a speed-driving rig (see carlaverse/hal/trainer/ftms_calibration.py)",
        )
    if args.ramp_s <= 0:
        return fail("calibrate", f"--ramp-s {args.ramp_s}: must be > 0 seconds")
    clock = ManualClock()
    trainer = ftms_sim.SimFtmsTrainer(ftms_sim.SimFtmsOptions(seed=args.seed), clock=clock)
    protocol = RampProtocol(ramp_s=args.ramp_s)
    with trainer:
        table = calibrate(trainer, protocol, trainer.drive, clock.advance, "ftms_sim")
    try:
        table.save(args.out)
    except OSError as exc:
        return fail("calibrate", f"cannot write {args.out}: {exc.strerror}")
    print(
        f"wrote {args.out}: {len(table.speeds_mps)} speeds × {len(table.forces_n)} forces "
        f"from {len(protocol.levels_percent)} ramps",
        file=sys.stderr,
    )
    return 0
