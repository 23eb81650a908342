"""What a study export reads from a run's output folder, and nothing else: the study log, the
trials' recordings and scenarios, and the answers file (issue 44.6).

Every row of every export table is keyed by who and what: participant, role, site, trial,
attempt, block, kind (main | practice), condition. The log says all of these but the site,
which only the study file holds (`--study`); without it the site is left empty. The
pseudonym -> person mapping is never read: nothing here can carry it into an export.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from carlaverse.study.answers import ANSWERS_NAME
from carlaverse.study.study_file import PSEUDONYM
from carlaverse.study.study_log import COMPLETED, LOG_NAME, StudyLogError, read_events
from carlaverse.study.trial import TRIALS_DIR

MIXED = "mixed"  # the condition of a trial-level row whose participants' conditions differ


@dataclass(frozen=True)
class Seat:
    """One participant in one trial attempt: the key columns of their rows."""

    participant: str
    role: str
    site: str
    condition: str

    def keys(self, attempt: Attempt) -> dict[str, Any]:
        return {"participant": self.participant, "role": self.role, "site": self.site,
                **attempt.keys(), "condition": self.condition}  # fmt: skip


@dataclass
class Attempt:
    """One trial attempt as the log tells it."""

    trial: str
    attempt: int
    kind: str = "main"  # main | practice
    block: int = 0
    conditions: dict[str, str] = field(default_factory=dict)  # participant -> condition
    links: dict[str, dict[str, float]] = field(default_factory=dict)  # participant -> link
    scenario: str = ""
    started_unix: float = float("nan")  # [s]
    ended_unix: float = float("nan")  # [s]
    live_unix: float = float("nan")  # [s] when every role was present
    outcome: str = "running"  # of the log's trial_end; "running": the log has none
    reason: str = ""
    view_error: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    recording: str = ""  # relative to the output folder
    notes: list[str] = field(default_factory=list)

    @property
    def completed(self) -> bool:
        return self.outcome == COMPLETED

    @property
    def practice(self) -> bool:
        return self.kind == "practice"

    @property
    def condition(self) -> str:
        """The trial's one condition, or `mixed` when its participants' differ."""
        found = set(self.conditions.values())
        return found.pop() if len(found) == 1 else MIXED

    def keys(self) -> dict[str, Any]:
        return {"trial": self.trial, "attempt": self.attempt, "block": self.block,
                "kind": self.kind, "practice": self.practice}  # fmt: skip


@dataclass
class StudyRun:
    """A run's output folder, read: its attempts in log order and who took part."""

    folder: Path
    study: str
    roles: dict[str, str]  # participant -> role
    sites: dict[str, str]  # participant -> site ("" without the study file)
    attempts: list[Attempt]
    notes: list[str] = field(default_factory=list)  # the operator's notes between trials

    def seats(self, attempt: Attempt) -> list[Seat]:
        return [Seat(pid, self.roles.get(pid, ""), self.sites.get(pid, ""), condition)
                for pid, condition in sorted(attempt.conditions.items())]  # fmt: skip

    def completed(self) -> list[Attempt]:
        return [a for a in self.attempts if a.completed]

    def recording(self, attempt: Attempt) -> Path:
        return self.folder / (attempt.recording or f"{TRIALS_DIR}/{attempt.trial}.mcap")

    def scenario_file(self, attempt: Attempt) -> Path:
        return self.folder / TRIALS_DIR / f"{attempt.trial}.scenario.yaml"

    @property
    def answers_file(self) -> Path:
        return self.folder / ANSWERS_NAME


def read_run(folder: Path, sites: dict[str, str] | None = None) -> StudyRun:
    """The run in `folder`; StudyLogError naming the file if it has no readable log."""
    log = folder / LOG_NAME
    if not log.is_file():
        raise StudyLogError(f"{folder}: no study log here ({LOG_NAME}): is it a study's --out?")
    study, roles = "", {}
    attempts: dict[tuple[str, int], Attempt] = {}
    latest: dict[str, Attempt] = {}  # trial -> its attempt begun last: where a note belongs
    between: list[str] = []
    for event in read_events(log):
        kind, trial = event["event"], str(event.get("trial", ""))
        if kind == "study":
            study, roles = str(event.get("study", "")), dict(event.get("participants", {}))
        elif kind == "trial_start":
            attempt = _started(event)
            attempts[(attempt.trial, attempt.attempt)] = latest[attempt.trial] = attempt
            roles |= {str(k): str(v) for k, v in dict(event.get("who", {})).items()}
        elif kind in ("trial_live", "trial_end"):
            key = (trial, int(event.get("attempt", 1)))
            _ended(attempts.setdefault(key, Attempt(trial, key[1])), event)
        elif kind == "note":
            _note(latest.get(trial), between, event)
    _check_pseudonyms(log, [*roles, *(p for a in attempts.values() for p in a.conditions)])
    return StudyRun(folder, study, roles, sites or {}, list(attempts.values()), between)


def _check_pseudonyms(log: Path, ids: list[str]) -> None:
    """A log edited by hand could name a person where a pseudonym belongs: refuse to export
    it rather than carry the name on (the study file admits codes alone)."""
    for pid in ids:
        if not re.fullmatch(PSEUDONYM, pid):
            raise StudyLogError(f"{log}: participant {pid!r} is not a pseudonym (up to four "
                                "letters, then 1-6 digits): not exporting")  # fmt: skip


def _note(attempt: Attempt | None, between: list[str], event: dict[str, Any]) -> None:
    """A note during a trial belongs to its attempt; one between trials to the run."""
    text = str(event.get("text", ""))
    if attempt is not None and attempt.outcome == "running":
        attempt.notes.append(text)
    else:
        trial = f" (trial {event['trial']})" if event.get("trial") else ""
        between.append(f"{event.get('t', '')}{trial}: {text}")


def _started(event: dict[str, Any]) -> Attempt:
    return Attempt(
        trial=str(event["trial"]), attempt=int(event.get("attempt", 1)),
        kind=str(event.get("kind", "main")), block=int(event.get("block", 0)),
        conditions={str(k): str(v) for k, v in dict(event.get("conditions", {})).items()},
        links=dict(event.get("links", {})), scenario=str(event.get("scenario", "")),
        started_unix=float(event.get("unix", "nan")), recording=str(event.get("recording", "")),
    )  # fmt: skip


def _ended(attempt: Attempt, event: dict[str, Any]) -> None:
    if event["event"] == "trial_live":
        attempt.live_unix = float(event.get("unix", "nan"))
        return
    attempt.ended_unix = float(event.get("unix", "nan"))
    attempt.outcome = str(event.get("outcome", ""))
    attempt.reason = str(event.get("reason", ""))
    attempt.view_error = dict(event.get("view_error", {}) or {})


def utc(unix_s: float) -> datetime | None:
    """A unix time as a UTC timestamp (None for none): Parquet and CSV keep it a time."""
    if unix_s != unix_s:  # nan: the log has no such moment
        return None
    return datetime.fromtimestamp(round(unix_s, 3), UTC)


def study_sites(study_file: Path | None) -> dict[str, str]:
    """participant -> site from a study file (ConfigError naming it), {} without one."""
    if study_file is None:
        return {}
    from carlaverse.study.study_file import load_study

    return {p.id: p.site for p in load_study(study_file).participants}


def as_json(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"), sort_keys=True)
