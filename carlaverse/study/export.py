"""`carlaverse study export`: a run's output folder as tidy tables and a report (issue 44.6).

    export_study(Path("runs/lane"), Path("runs/lane/export"))

writes, into the export folder, one table per measure (each as Parquet and CSV):

    trials          one row per participant per trial attempt: outcome, times, link, view error
    trajectories    per participant per completed trial: distance, speed, acceleration (from
                    every recorded pose)
    encounters      per pair per completed trial: least TTC, gap, DRAC, PET, the flags
    triggers        per scenario trigger per completed trial: fired or not, when, its values
    questionnaires  per participant per questionnaire: every score and item (long)
    lsl             per LSL stream per completed trial: samples and coverage

with `columns.json` (every column of every table, with its unit), `README.md` and
`report.html` (self-contained: plots inline, no external URL). Only pseudonyms are read and
written: the pseudonym -> person mapping is never an input.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pyarrow as pa

from carlaverse.analysis.export import write_table
from carlaverse.analysis.surrogate import Thresholds, measure
from carlaverse.analysis.tracks import read_recording
from carlaverse.recording.sink import RecordingError
from carlaverse.study import export_measures as em
from carlaverse.study import export_tables as et
from carlaverse.study.export_inputs import StudyRun, read_run, study_sites
from carlaverse.study.export_paths import read_poses

COLUMNS = {
    "trials": et.TRIALS,
    "trajectories": et.TRAJECTORIES,
    "encounters": et.ENCOUNTERS,
    "triggers": et.TRIGGERS,
    "questionnaires": em.QUESTIONNAIRES,
    "lsl": em.LSL,
}


@dataclass
class Export:
    """What an export wrote, and what it left out and why (one line each)."""

    folder: Path
    tables: dict[str, list[dict[str, Any]]]
    excluded: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def export_study(
    run_folder: Path,
    dest: Path,
    study_file: Path | None = None,
    rate_hz: float = 10.0,
    thresholds: Thresholds | None = None,
    progress: Callable[[str], None] = lambda _: None,
) -> Export:
    """Read the run in `run_folder`, write its tables and report into `dest`."""
    from carlaverse.study.export_report import write_report

    thresholds = thresholds or Thresholds()
    run = read_run(run_folder, study_sites(study_file))
    tables, excluded = collect(run, rate_hz, thresholds, progress)
    dest.mkdir(parents=True, exist_ok=True)
    done = Export(dest, tables, excluded)
    for name, rows in tables.items():
        done.files += write_table(table_of(rows, COLUMNS[name]), dest, name)
    done.files.append(_write_json(dest / "columns.json", COLUMNS))
    done.files.append(_write_readme(dest / "README.md", run, rate_hz, thresholds, excluded))
    done.files.append(write_report(dest / "report.html", run, tables, excluded, thresholds))
    return done


def collect(
    run: StudyRun, rate_hz: float, th: Thresholds, progress: Callable[[str], None]
) -> tuple[dict[str, list[dict[str, Any]]], list[str]]:
    """Every table's rows, and what was left out of them (one line each)."""
    tables: dict[str, list[dict[str, Any]]] = {name: [] for name in COLUMNS}
    tables["trials"] = et.trial_rows(run)
    excluded = _not_completed(run)
    for attempt in run.completed():
        path = run.recording(attempt)
        progress(f"trial {attempt.trial}: {path.name}")
        try:
            read = read_recording(path, rate_hz)
            poses = read_poses(path, set(attempt.conditions))
            lsl = em.lsl_rows(attempt, path)
        except (RecordingError, OSError) as exc:
            excluded.append(f"trial {attempt.trial}: its recording cannot be read ({exc})")
            continue
        pairs, conflicts = measure(read.tracks, th)
        measured = et.Measured(attempt, read, pairs, conflicts, poses)
        tables["trajectories"] += et.trajectory_rows(run, measured)
        tables["encounters"] += et.encounter_rows(run, measured)
        tables["triggers"] += et.trigger_rows(run, measured)
        tables["lsl"] += lsl
    tables["questionnaires"], left_out = em.questionnaire_rows(run)
    return tables, excluded + left_out


def _not_completed(run: StudyRun) -> list[str]:
    return [f"trial {a.trial} attempt {a.attempt}: {a.outcome}"
            + (f" ({a.reason})" if a.reason else "") + ": not measured (only completed "
            "attempts have a recording under the trial's name)"
            for a in run.attempts if not a.completed]  # fmt: skip


def table_of(rows: list[dict[str, Any]], columns: dict[str, str]) -> pa.Table:
    """The rows as a table with exactly the documented columns, in their order."""
    for row in rows:
        extra = set(row) - set(columns)
        if extra:
            raise ValueError(f"export row has undocumented columns {sorted(extra)}")
    return pa.table({name: [row.get(name) for row in rows] for name in columns})


def _write_json(path: Path, data: Any) -> Path:
    path.write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    return path


def _write_readme(
    path: Path, run: StudyRun, rate_hz: float, th: Thresholds, excluded: list[str]
) -> Path:
    stamp = datetime.now(UTC).isoformat(timespec="seconds")
    lines = [
        f"# Study {run.study}: export", "",
        f"Exported {stamp} from the study log, recordings and answers of a run "
        f"({len(run.attempts)} trial attempts, {len(run.completed())} completed). Participants "
        "appear by pseudonym only.", "",
        "Each table is a Parquet file and a CSV file with the same rows; `columns.json` "
        "describes every column. Trajectories are summarised from every recorded pose; encounters "
        "come from `carlaverse analyze`'s analysis of each completed trial's recording, on a "
        f"{rate_hz:g} Hz grid: TTC threshold "
        f"{th.ttc_s:g} s, horizon {th.ttc_horizon_s:g} s, DRAC limit "
        f"{th.drac_limit_mps2:g} m/s², standstill below {th.standstill_mps:g} m/s.", "",
        "## Tables", "",
        *(f"- `{name}`: {len(cols)} columns" for name, cols in COLUMNS.items()), "",
        "## Notes between trials", "",
        *([f"- {line}" for line in run.notes] or ["- none"]), "",
        "## Left out", "",
        *([f"- {line}" for line in excluded] or ["- nothing"]), "",
    ]  # fmt: skip
    path.write_text("\n".join(lines))
    return path
