"""Where a study run stands, read from its log alone: one row per trial and the run's state.

`carlaverse study status DIR` prints it; a launcher page or an export reads the same rows, so
the log stays the one record of what happened (study_log.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec

from carlaverse.study.study_log import COMPLETED, LOG_NAME, read_events


class TrialRow(msgspec.Struct):
    """One trial as the log tells it (its latest attempt)."""

    trial: str
    attempts: int = 0
    outcome: str = ""  # of the latest attempt; "running" while it runs; "" never started
    conditions: dict[str, str] = {}
    started: str = ""  # UTC, ISO 8601, of the latest attempt
    ended: str = ""
    recording: str = ""  # relative to the run's folder; its final name once completed
    view_p95_m: dict[str, float] = {}  # "P01>P02" -> p95 view error [m]
    notes: list[str] = []


class RunStatus(msgspec.Struct):
    study: str
    state: str  # not started | running | paused | stopped | ended
    trials: list[TrialRow]
    completed: int


def run_status(out: Path) -> RunStatus:
    """The run in `out` as its log has it; FileNotFoundError if there is no log."""
    rows: dict[str, TrialRow] = {}
    study, state = "", "not started"
    for event in read_events(out / LOG_NAME):
        kind, trial = event["event"], str(event.get("trial", ""))
        if kind == "study":
            study = str(event.get("study", ""))
        elif kind == "trial_start":
            _start(rows.setdefault(trial, TrialRow(trial)), event)
            state = "running"
        elif kind == "trial_end":
            _end(rows.setdefault(trial, TrialRow(trial)), event)
            state = "ended"
        elif kind == "note" and trial:
            rows.setdefault(trial, TrialRow(trial)).notes.append(str(event.get("text", "")))
        elif kind in ("paused", "unpaused", "stopped", "resumed"):
            state = {"paused": "paused", "stopped": "stopped"}.get(kind, "running")
    completed = sum(row.outcome == COMPLETED for row in rows.values())
    return RunStatus(study, state, list(rows.values()), completed)


def _start(row: TrialRow, event: dict[str, Any]) -> None:
    row.attempts = int(event.get("attempt", row.attempts + 1))
    row.outcome = "running"
    row.conditions = dict(event.get("conditions", {}))
    row.started, row.ended = str(event.get("t", "")), ""
    row.recording = str(event.get("recording", ""))


def _end(row: TrialRow, event: dict[str, Any]) -> None:
    row.outcome = str(event.get("outcome", ""))
    row.ended = str(event.get("t", ""))
    if row.outcome != COMPLETED:
        row.recording = ""  # set aside under the attempt's name (trial.set_aside_name)
    errors = event.get("view_error") or {}
    row.view_p95_m = {
        f"{viewer}>{other}": round(float(figures["p95_m"]), 3)
        for viewer, others in errors.items()
        for other, figures in others.items()
    }
