"""The study log: one JSON object per line, appended and fsync'd, so it survives a crash.

The runner is its one writer. Every line has `event` and `t` (UTC, ISO 8601) and `unix`
([s]); the events (docs: README "Studies", the study log):

    study        the run began: study name, digest of the study file, run_id, trial count
    resumed      a later run went on from the log
    trial_start  trial, attempt, session, kind, block, conditions, links, scenario, seed,
                 who (participant -> role), recording (path relative to the output folder)
    trial_live   every role present: the trial's clock starts (present: participant -> node)
    trial_end    trial, attempt, outcome (completed | aborted | redo | lost | killed |
                 not_started | failed), reason, view_error (participant -> other -> figures)
    questionnaire  trial, attempt, questionnaire (its id), missing (participants who did not
                 answer in full; their answers are in OUT/answers.jsonl, answers.py)
    note         trial (or ""), text
    paused / unpaused / stopped

A line cut short by a kill (no newline at the end of the file) is cut off when the log is
opened again; a `trial_start` with no `trial_end` is closed with outcome `killed`, so the
trial is redone and a trial completed once is never run again.
"""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

LOG_NAME = "study-log.jsonl"
COMPLETED = "completed"


class StudyLogError(ValueError):
    """A log that cannot be read, or that belongs to another study."""


@dataclass
class LogState:
    """What the log says has happened."""

    digest: str = ""
    run_id: str = ""  # names this run's sessions apart from any other run of the study
    completed: set[str] = field(default_factory=set)
    attempts: dict[str, int] = field(default_factory=dict)  # trial -> attempts started
    open_trial: tuple[str, int] | None = None  # (trial, attempt) started, never ended
    events: int = 0


class StudyLog:
    """Append-only, fsync'd JSON lines at `path`."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.state = LogState()
        if path.exists():
            self._cut_torn_tail()
            for event in read_events(path):
                self._absorb(event)

    def append(self, event: str, **fields: Any) -> dict[str, Any]:
        """Write one event and make it durable before returning."""
        now = time.time()
        stamp = datetime.fromtimestamp(now, UTC).isoformat(timespec="milliseconds")
        record = {"event": event, "t": stamp, "unix": round(now, 3), **fields}
        line = json.dumps(record, separators=(",", ":"), ensure_ascii=False) + "\n"
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line.encode())
            os.fsync(fd)
        finally:
            os.close(fd)
        self._absorb(record)
        return record

    def _absorb(self, record: dict[str, Any]) -> None:
        s = self.state
        s.events += 1
        event, trial = record.get("event"), str(record.get("trial", ""))
        if event == "study":
            s.digest = str(record.get("digest", ""))
            s.run_id = str(record.get("run_id", ""))
        elif event == "trial_start":
            attempt = int(record.get("attempt", 1))
            s.attempts[trial] = max(s.attempts.get(trial, 0), attempt)
            s.open_trial = (trial, attempt)
        elif event == "trial_end":
            s.open_trial = None
            if record.get("outcome") == COMPLETED:
                s.completed.add(trial)

    def _cut_torn_tail(self) -> None:
        """Drop a last line a kill cut short (no newline): appended to, it would spoil the next."""
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            keep = data.rfind(b"\n") + 1
            log.warning("%s: dropping a torn last line (%d bytes)", self.path, len(data) - keep)
            with self.path.open("r+b") as f:
                f.truncate(keep)
                os.fsync(f.fileno())


def read_events(path: Path) -> Iterator[dict[str, Any]]:
    """The log's events in order; StudyLogError names the line that is not an event."""
    with path.open(encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if not line.endswith("\n"):
                return  # a torn last line: not yet an event
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                raise StudyLogError(f"{path}:{number}: not a JSON line: {exc.msg}") from exc
            if not isinstance(record, dict) or "event" not in record:
                raise StudyLogError(f"{path}:{number}: not a study log event")
            yield record
