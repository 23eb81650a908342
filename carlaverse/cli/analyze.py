"""`carlaverse analyze FILE.mcap --out DIR`: trajectories and surrogate safety measures.

Writes into DIR:

    actors.parquet/.csv         who each id is: participant or NPC, kind, size, when seen,
                                the lanes it drove along
    trajectories.parquet/.csv   every road user (humans and NPCs) at --rate Hz
    events.parquet/.csv         every world event (spawns, leaves, contacts, triggers)
    pairs.parquet/.csv          per pair that came within --near m, pairs with a participant
                                first: min TTC, time below the TTC threshold, min gap, max
                                DRAC, both road users' kinds and lanes at the worst moment
    conflicts.parquet/.csv      every crossing of two paths with its PET
    summary.json                the headline numbers
    report.png, report.html     the map, the trajectories, the conflicts and the tables

Every time `t…` (session time) has `t…_rel_s` beside it: seconds from the recording's start,
the number `carlaverse render FILE --at S` takes to show that moment. Queues are no encounter
(both slower than 0.5 m/s, or two NPCs pulling up into one; a participant keeps its TTC), and
a DRAC above 10 m/s² (more than friction allows a tyre) is flagged, not a headline. The
measures and their definitions are in `carlaverse.analysis.surrogate`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TextIO

from carlaverse.cli.common import fail, json_stdout
from carlaverse.cli.exit_codes import Exit

NAME = "analyze"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Analyse a recording: per-participant trajectories at a fixed rate (Parquet and CSV), "
        "the events, surrogate safety measures for every pair of road users (TTC, PET, "
        "minimum gap, DRAC) and a report with the map, trajectories and conflicts. Pairs with "
        "a participant come first; times are seconds from the recording's start (what render "
        "--at takes), session time beside them."
    )
    parser.add_argument("recording", type=Path, metavar="FILE.mcap", help="a session recording")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    parser.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                        help="trajectory sample rate [Hz] (default 10)")  # fmt: skip
    parser.add_argument("--ttc", type=float, default=1.5, metavar="S",
                        help="TTC/PET threshold [s] counted as critical (default 1.5)")  # fmt: skip
    parser.add_argument("--near", type=float, default=30.0, metavar="M",
                        help="measure pairs coming within this [m] (default 30)")  # fmt: skip
    parser.add_argument("--pet-max", type=float, default=10.0, metavar="S",
                        help="longest PET counted as a conflict [s] (default 10)")  # fmt: skip
    parser.add_argument("--standstill", type=float, default=0.5, metavar="MPS",
                        help="both slower than this [m/s]: at rest in a queue, left out of "
                        "TTC and DRAC (default 0.5); NPCs coming to rest together are left out "
                        "of TTC too; 0 measures every instant")  # fmt: skip
    parser.add_argument("--drac-limit", type=float, default=10.0, metavar="MPS2",
                        help="DRAC above this [m/s²] is flagged implausible, not a headline "
                        "(default 10: above mu g = 9.8 for mu = 1, no tyre brakes "
                        "harder)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    with json_stdout(True) as out:  # its stdout is the summary's JSON and nothing else
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    from carlaverse.analysis.run import AnalysisError, analyze
    from carlaverse.analysis.surrogate import Thresholds

    for name in ("rate", "ttc", "near", "pet_max", "drac_limit"):
        if not getattr(args, name) > 0:
            return fail(NAME, f"--{name.replace('_', '-')} must be > 0, got {getattr(args, name)}")
    if not args.standstill >= 0:  # 0: nothing counts as standing, every instant is measured
        return fail(NAME, f"--standstill must be >= 0, got {args.standstill}")
    if not args.recording.is_file():
        return fail(NAME, f"{args.recording}: no such recording")
    th = Thresholds(ttc_s=args.ttc, near_m=args.near, pet_max_s=args.pet_max,
                    standstill_mps=args.standstill, drac_limit_mps2=args.drac_limit)  # fmt: skip
    started = time.monotonic()
    try:
        result = analyze(args.recording, args.out, args.rate, th, progress=_progress)
    except AnalysisError as exc:
        return fail(NAME, str(exc), Exit.FAILED)
    out.write(json.dumps(result, indent=2) + "\n")
    out.flush()
    print(f"analysed {args.recording} in {time.monotonic() - started:.1f} s; "
          f"open {args.out / 'report.html'}", file=sys.stderr)  # fmt: skip
    return Exit.OK


def _progress(message: str) -> None:
    print(f"analyze: {message}", file=sys.stderr, flush=True)
