"""`carlaverse study` in-process: one-line errors with exit 2, the plan table, the people file's
rules, and control commands handed to a runner's folder."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from carlaverse.cli import main
from carlaverse.study import control
from carlaverse.study.run_lock import RunLock
from carlaverse.study.study_log import StudyLog

STUDY = """
name: dyad
participants:
  - {id: P01, role: driver, kind: drive}
  - {id: P02, role: cyclist, kind: bike}
conditions:
  - {id: direct}
  - {id: lagged, link: {delay_ms: 150, jitter_ms: 20}}
design: {order: latin, blocks: 2}
"""


@pytest.fixture
def study(tmp_path: Path) -> Path:
    folder = tmp_path / "study"
    folder.mkdir()
    path = folder / "dyad.yaml"
    path.write_text(STUDY)
    return path


def test_validate_and_plan(study: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "validate", str(study)]) == 0
    assert "valid study dyad: 2 participants, 2 conditions, 4 trials" in capsys.readouterr().err
    assert main(["study", "plan", str(study)]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()]
    assert rows[0] == ["trial", "kind", "block", "P01", "P02"]
    assert rows[1:] == [["t01", "main", "1", "direct", "lagged"],
                        ["t02", "main", "1", "lagged", "direct"],
                        ["t03", "main", "2", "direct", "lagged"],
                        ["t04", "main", "2", "lagged", "direct"]]  # fmt: skip
    assert main(["study", "plan", str(study), "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert [t["conditions"]["P02"] for t in plan["trials"]] == ["lagged", "direct"] * 2


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (("id: P02", "id: Bob"), "$.participants[1].id"),
        (("jitter_ms: 20", "jitter_ms: 200"), "$.conditions[1].link.jitter_ms"),
        (("kind: bike", "kind: bike, config: nowhere.yaml"), "nowhere.yaml: no such file"),
    ],
)
def test_bad_study_is_one_line_exit_2(
    study: Path, capsys: pytest.CaptureFixture[str], edit: tuple[str, str], says: str
) -> None:
    study.write_text(STUDY.replace(*edit))
    assert main(["study", "validate", str(study)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("carlaverse study: ") and says in err and "\n" not in err


def test_node_config_override_is_checked_by_the_kind(
    study: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    override = "node_config: {P01: {node: {pose_rate_hz: 60, colour: red}}}"
    study.write_text(STUDY.replace("link: {delay_ms: 150, jitter_ms: 20}", override))
    assert main(["study", "validate", str(study)]) == 2
    err = capsys.readouterr().err
    assert "condition lagged's node_config" in err and "colour" in err


def _people(path: Path, mode: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("P01: Jane Doe\n")
    path.chmod(mode)
    return path


def test_people_file_must_be_private_and_outside(
    study: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    readable = _people(tmp_path / "private" / "people.yaml", 0o640)
    assert main(["study", "run", str(study), "--out", str(out), "--people", str(readable)]) == 2
    assert "chmod 600" in capsys.readouterr().err
    inside = _people(study.parent / "people.yaml", 0o600)
    assert main(["study", "run", str(study), "--out", str(out), "--people", str(inside)]) == 2
    err = capsys.readouterr().err
    assert "outside the study and output folders" in err and "Jane" not in err
    reversed_file = tmp_path / "private" / "reversed.yaml"
    reversed_file.write_text("Jane Doe: P01\n")
    reversed_file.chmod(0o600)
    flipped = ["study", "run", str(study), "--out", str(out), "--people", str(reversed_file)]
    assert main(flipped) == 2
    err = capsys.readouterr().err
    assert "PSEUDONYM: PERSON" in err and "Jane" not in err
    in_out = _people(out / "people.yaml", 0o600)
    assert main(["study", "run", str(study), "--out", str(out), "--people", str(in_out)]) == 2
    assert not (out / "study-log.jsonl").exists()  # refused before anything ran


def test_control_hands_one_command_over(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "control", str(tmp_path), "note", "room", "too", "warm"]) == 0
    assert control.take(tmp_path) == control.Command("note", "room too warm")
    assert control.take(tmp_path) is None  # taken once
    assert main(["study", "control", str(tmp_path), "explode"]) == 2
    assert "unknown study command 'explode'" in capsys.readouterr().err
    (tmp_path / "control-0-1.cmd").write_text("pause now\n")  # written by hand, wrongly
    taken = control.take(tmp_path)
    assert taken is not None and taken.name == "note" and "pause takes no text" in taken.text
    # two commands sent at once are both kept, and taken in the order sent
    control.send(tmp_path, "note first")
    control.send(tmp_path, "pause")
    assert control.take(tmp_path) == control.Command("note", "first")
    assert control.take(tmp_path) == control.Command("pause")
    assert control.take(tmp_path) is None


def test_status_reads_the_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "status", str(tmp_path)]) == 2
    assert "no study log here" in capsys.readouterr().err
    log = StudyLog(tmp_path / "study-log.jsonl")
    log.append("study", study="dyad", digest="d", run_id="abc", trials=2)
    log.append("trial_start", trial="t01", attempt=1, conditions={"P01": "direct"},
               recording="trials/t01.mcap")  # fmt: skip
    log.append("trial_end", trial="t01", attempt=1, outcome="completed",
               view_error={"P01": {"P02": {"samples": 9, "p50_m": 0.1, "p95_m": 0.25,
                                           "max_m": 0.3}}})  # fmt: skip
    log.append("trial_start", trial="t02", attempt=1, conditions={"P01": "lagged"},
               recording="trials/t02.mcap")  # fmt: skip
    log.append("paused", trial="t02")
    assert main(["study", "status", str(tmp_path), "--json"]) == 0
    status = json.loads(capsys.readouterr().out)
    assert status["state"] == "paused" and status["completed"] == 1
    first, second = status["trials"]
    assert first["view_p95_m"] == {"P01>P02": 0.25} and first["recording"] == "trials/t01.mcap"
    assert second["outcome"] == "running"


def test_one_runner_per_output_folder(
    study: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    (out / "trials").mkdir(parents=True)
    held = RunLock(out).acquire()  # as a runner running into `out` holds it
    try:
        assert main(["study", "run", str(study), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"another study runner (pid {os.getpid()}) runs into this folder" in err
        assert not (out / "study-log.jsonl").exists()  # refused before the log was touched
    finally:
        held.release()
    RunLock(out).acquire().release()  # released: the next runner gets it
