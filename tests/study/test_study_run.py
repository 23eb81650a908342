"""A whole study, end to end, headless: two participants (a driver and a cyclist on simulated
devices), two conditions counterbalanced by a balanced Latin square over two blocks (four
trials), the runner killed outright in the middle of a trial and run again.

What it shows (issue 44 items 1, 2, 5, 7, 8):
- the killed trial is logged `killed` and redone as attempt 2; no completed trial runs twice;
- an operator's note lands in the log with its trial, and `redo` reruns the trial at once;
- each completed trial has its recording, whose metadata holds the trial's conditions and the
  link each participant had; the lagged participant's link delay is what the file says;
- each trial's report gives, per participant, the view error of the other against the truth;
- the pseudonym -> person mapping reaches neither the log nor any recording (searched in the
  decompressed records), while the pseudonyms themselves do (the search sees the contents);
- the processes the killed runner left are stopped by the next run.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
from pathlib import Path

import pytest
from mcap.exceptions import EndOfFile
from mcap.records import Attachment, Channel, Message, Metadata
from mcap.stream_reader import StreamReader

from carlaverse.procs import Child, stop_children
from carlaverse.procs import start as start_child
from carlaverse.study import control
from carlaverse.study.leftovers import CHILDREN_NAME
from carlaverse.study.status import run_status
from carlaverse.study.trial_sink import WITHHELD

pytestmark = pytest.mark.timeout(600)

STUDY = """
name: e2e
launch: local
participants:
  - {id: P01, role: driver, site: lab-a, kind: drive}
  - {id: P02, role: cyclist, site: lab-b, kind: bike}
conditions:
  - {id: direct}
  - id: lagged
    link: {delay_ms: 150, jitter_ms: 10}
design: {order: latin, blocks: 2}
trial: {duration_s: 1.5, start_timeout_s: 150, view_probe_hz: 10}
"""
PEOPLE = {"P01": "Zelda Quimby-Marlowe", "P02": "Ignatius Blorfendorf"}
LAGGED_DELAY_MS = 150.0


def _events(out: Path) -> list[dict]:
    path = out / "study-log.jsonl"
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.endswith("}")]


def _wait_for(
    out: Path, event: str, trial: str, runner: Child, timeout_s: float, attempt: int = 1
) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if any(e["event"] == event and e.get("trial") == trial
               and e.get("attempt", 1) == attempt for e in _events(out)):  # fmt: skip
            return
        assert runner.running, f"the runner exited ({runner.exit_code}): {runner.log.text()}"
        time.sleep(0.1)
    raise AssertionError(f"no {event} of {trial} within {timeout_s} s: {runner.log.text()}")


def _send(out: Path, command: str) -> None:
    """What `carlaverse study control OUT COMMAND` does (test_study_cli runs the command),
    in-process so it lands within the short trial; then wait until the runner took it."""
    control.send(out, command)
    deadline = time.monotonic() + 30
    while control.pending(out):
        assert time.monotonic() < deadline, f"the runner did not take {command}"
        time.sleep(0.05)


def _mcap_text(path: Path) -> str:
    """Everything a recording holds, decompressed, as text to search (a killed attempt's
    file ends without its footer: read up to where it stops)."""
    parts: list[str] = []
    with path.open("rb") as f, contextlib.suppress(EndOfFile):
        for record in StreamReader(f, skip_magic=False).records:
            if isinstance(record, Message | Attachment):
                parts.append(record.data.decode("utf-8", "replace"))
            elif isinstance(record, Metadata):
                parts.append(json.dumps(record.metadata))
            elif isinstance(record, Channel):
                parts.append(record.topic + json.dumps(record.metadata))
    return "\n".join(parts)


def _all_metadata(path: Path, name: str) -> list[dict[str, str]]:
    with path.open("rb") as f:
        return [dict(r.metadata) for r in StreamReader(f, skip_magic=False).records
                if isinstance(r, Metadata) and r.name == name]  # fmt: skip


def _metadata(path: Path, name: str) -> dict[str, str]:
    with path.open("rb") as f:
        for record in StreamReader(f, skip_magic=False).records:
            if isinstance(record, Metadata) and record.name == name:
                return dict(record.metadata)
    raise AssertionError(f"{path} has no metadata {name}")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    return state != "Z"


def test_study_killed_mid_trial_resumes_and_completes(tmp_path: Path) -> None:
    (tmp_path / "study").mkdir()
    study = tmp_path / "study" / "e2e.yaml"
    study.write_text(STUDY)
    people = tmp_path / "private" / "people.yaml"
    people.parent.mkdir()
    people.write_text("".join(f"{k}: {v}\n" for k, v in PEOPLE.items()))
    people.chmod(0o600)
    out = tmp_path / "out"
    argv = ["study", "run", str(study), "--out", str(out), "--people", str(people)]

    first = start_child(argv, name="runner 1")
    try:
        _wait_for(out, "trial_live", "t02", first, 200)
        left_by_first = [e["pid"] for e in json.loads((out / CHILDREN_NAME).read_text())]
        os.kill(first.proc.pid, signal.SIGKILL)  # a crash: no cleanup of any kind
        first.proc.wait()
    finally:
        stop_children([first])
    second = start_child(argv, name="runner 2")
    try:
        # The operator has t03 redone, and notes something during its second attempt.
        _wait_for(out, "trial_live", "t03", second, 200)
        _send(out, "redo")
        _wait_for(out, "trial_start", "t03", second, 60, attempt=2)
        _send(out, "note P02 sneezed")
        deadline = time.monotonic() + 300
        while second.running and time.monotonic() < deadline:
            time.sleep(0.2)
        second.finish_reading()
        assert second.exit_code == 0, second.log.text()
    finally:
        stop_children([second])

    events = _events(out)
    starts = [(e["trial"], e["attempt"]) for e in events if e["event"] == "trial_start"]
    ends = [(e["trial"], e["attempt"], e["outcome"]) for e in events if e["event"] == "trial_end"]
    assert starts == [("t01", 1), ("t02", 1), ("t02", 2), ("t03", 1), ("t03", 2), ("t04", 1)]
    assert ends == [("t01", 1, "completed"), ("t02", 1, "killed"), ("t02", 2, "completed"),
                    ("t03", 1, "redo"), ("t03", 2, "completed"),
                    ("t04", 1, "completed")]  # fmt: skip
    notes = [(e["trial"], e["text"]) for e in events if e["event"] == "note"]
    assert notes == [("t03", "P02 sneezed")]
    assert [e["event"] for e in events].count("resumed") == 1

    # Counterbalanced: Williams rows for two conditions are (direct, lagged), (lagged, direct)
    conditions = {e["trial"]: e["conditions"] for e in events if e["event"] == "trial_start"}
    assert [conditions[t]["P01"] for t in ("t01", "t02", "t03", "t04")] == [
        "direct", "lagged", "direct", "lagged"]  # fmt: skip
    assert [conditions[t]["P02"] for t in ("t01", "t02", "t03", "t04")] == [
        "lagged", "direct", "lagged", "direct"]  # fmt: skip

    trials = out / "trials"
    assert sorted(p.name for p in trials.glob("*.mcap")) == [
        "t01.mcap", "t02.attempt1.killed.mcap", "t02.mcap", "t03.attempt1.redo.mcap",
        "t03.mcap", "t04.mcap"]  # fmt: skip
    meta = _metadata(trials / "t01.mcap", "carlaverse.study.trial")
    assert json.loads(meta["conditions"]) == {"P01": "direct", "P02": "lagged"}
    links = json.loads(meta["links"])
    assert links["P02"]["delay_ms"] == LAGGED_DELAY_MS and links["P01"]["delay_ms"] == 0.0

    for end in (e for e in events if e["event"] == "trial_end" and e["outcome"] == "completed"):
        figures = end["view_error"]
        assert set(figures) == {"P01", "P02"}, end
        assert figures["P01"]["P02"]["samples"] > 0 and figures["P02"]["P01"]["samples"] > 0
        for seen in (figures["P01"]["P02"], figures["P02"]["P01"]):
            assert 0.0 <= seen["p50_m"] <= seen["p95_m"] <= seen["max_m"]

    # Privacy: the names appear nowhere the study wrote; the pseudonyms do.
    written = [(out / "study-log.jsonl").read_text()]
    written += [_mcap_text(p) for p in trials.glob("*.mcap")]
    written += [p.read_text() for p in trials.glob("*.yaml")]
    everything = "\n".join(written)
    for person in PEOPLE.values():
        for word in person.split():
            assert word not in everything
    assert "P01" in _mcap_text(trials / "t03.mcap") and "P02" in everything
    # what the participants' machines are called is withheld, keyed by pseudonym still
    records = _all_metadata(trials / "t03.mcap", "carlaverse.hostnames")  # one per refresh
    assert {pid for hosts in records for pid in hosts} >= {"P01", "P02"}
    assert {value for hosts in records for value in hosts.values()} == {WITHHELD}

    # `study status` tells the same story from the log
    status = run_status(out)
    assert (status.state, status.completed) == ("ended", 4)
    assert [(r.trial, r.attempts, r.outcome) for r in status.trials] == [
        ("t01", 1, "completed"), ("t02", 2, "completed"), ("t03", 2, "completed"),
        ("t04", 1, "completed")]  # fmt: skip
    assert status.trials[2].notes == ["P02 sneezed"]
    assert status.trials[1].recording == "trials/t02.mcap"
    assert set(status.trials[0].view_p95_m) == {"P01>P02", "P02>P01"}

    # The killed run's router, authority and agents were stopped by the second run.
    assert not [pid for pid in left_by_first if _alive(pid)]
    assert not (out / CHILDREN_NAME).exists()
