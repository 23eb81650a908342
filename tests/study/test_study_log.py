"""The study log survives a kill: durable lines, a torn last line cut off, an open trial
closed as killed, so resuming redoes it and never repeats a completed one."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from carlaverse.study.study_log import StudyLog, StudyLogError, read_events


def test_state_after_a_kill_mid_trial(tmp_path: Path) -> None:
    path = tmp_path / "study-log.jsonl"
    first = StudyLog(path)
    first.append("study", digest="abc", trials=3)
    first.append("trial_start", trial="t01", attempt=1)
    first.append("trial_end", trial="t01", attempt=1, outcome="completed")
    first.append("trial_start", trial="t02", attempt=1)
    with path.open("ab") as f:  # the kill came halfway through a line
        f.write(b'{"event":"note","tr')
    again = StudyLog(path)
    assert again.state.digest == "abc"
    assert again.state.completed == {"t01"}
    assert again.state.open_trial == ("t02", 1)
    assert again.state.attempts == {"t01": 1, "t02": 1}
    again.append("trial_end", trial="t02", attempt=1, outcome="killed")
    events = list(read_events(path))
    assert [e["event"] for e in events] == ["study", "trial_start", "trial_end", "trial_start",
                                            "trial_end"]  # fmt: skip
    assert all(line.endswith("\n") for line in path.read_text().splitlines(keepends=True))
    assert StudyLog(path).state.open_trial is None


def test_each_line_is_json_with_time(tmp_path: Path) -> None:
    log = StudyLog(tmp_path / "log.jsonl")
    log.append("note", trial="", text="room too warm")
    (line,) = (tmp_path / "log.jsonl").read_text().splitlines()
    record = json.loads(line)
    assert record["event"] == "note" and record["text"] == "room too warm"
    assert record["t"].endswith("+00:00") and record["unix"] > 1.7e9


def test_a_spoiled_line_is_named(tmp_path: Path) -> None:
    path = tmp_path / "log.jsonl"
    path.write_text('{"event":"study"}\nnot json\n')
    with pytest.raises(StudyLogError, match=r"log.jsonl:2: not a JSON line"):
        StudyLog(path)
