"""`carlaverse study export OUT [--to DIR] [--study FILE]`: a study run as tables and a report.

An action of `carlaverse study` (`add_parser`, `run`); the tables, their columns and the
report are described in `carlaverse.study.export`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from carlaverse.cli.common import fail, say, tell
from carlaverse.cli.exit_codes import Exit

NAME = "study export"
EXPORT_DIR = "export"  # default: inside the run's folder


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """The `export` action's parser, added to `carlaverse study`'s actions."""
    parser = sub.add_parser(
        "export", help="tidy tables (Parquet, CSV) and an HTML report of a run",
        description="One table per measure across participants x trials x conditions "
        "(trials, trajectories, encounters with TTC/PET/DRAC, triggers, questionnaires, LSL "
        "coverage), each as Parquet and CSV, their columns in columns.json, and report.html "
        "(self-contained). Pseudonyms only: the people file is never read.",
    )  # fmt: skip
    add_arguments(parser)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("out", type=Path, help="the run's output folder (study run --out)")
    parser.add_argument("--to", type=Path, metavar="DIR",
                        help=f"where to write (default OUT/{EXPORT_DIR})")  # fmt: skip
    parser.add_argument("--study", type=Path, metavar="FILE",
                        help="the study file, for the participants' sites")  # fmt: skip
    parser.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                        help="analysis grid [Hz] (default 10, as carlaverse analyze)")  # fmt: skip
    parser.add_argument("--ttc", type=float, default=1.5, metavar="S",
                        help="TTC threshold [s] for time below (default 1.5)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    from carlaverse.analysis.surrogate import Thresholds
    from carlaverse.config import ConfigError
    from carlaverse.study.export import export_study
    from carlaverse.study.study_log import StudyLogError

    for name in ("rate", "ttc"):
        if not getattr(args, name) > 0:
            return fail(NAME, f"--{name} must be > 0, got {getattr(args, name)}")
    dest = args.to if args.to is not None else args.out / EXPORT_DIR
    try:
        done = export_study(args.out, dest, args.study, args.rate, Thresholds(ttc_s=args.ttc),
                            progress=say(NAME))  # fmt: skip
    except (ConfigError, StudyLogError) as exc:
        return fail(NAME, str(exc))
    except OSError as exc:
        return fail(NAME, f"cannot write {dest}: {exc}", Exit.FAILED)
    counts = ", ".join(f"{name} {len(rows)}" for name, rows in done.tables.items())
    tell(f"carlaverse {NAME}: {dest}: {counts} rows; report.html; "
         f"{len(done.excluded)} things left out (README.md says which)")  # fmt: skip
    return Exit.OK
