"""An externally launched study: the runner says what each participant's machine runs, the
participant's agent is started apart (as a lab would, from the printed line), and the
operator's pause holds the next trial until `resume`."""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

import pytest

from carlaverse.procs import Child, stop_children
from carlaverse.procs import start as start_child
from carlaverse.study import control

pytestmark = pytest.mark.timeout(400)

STUDY = """
name: ext
launch: external
participants:
  - {id: P07, role: cyclist, site: lab-b, kind: bike}
conditions:
  - {id: calm}
  - {id: lagged, link: {delay_ms: 80}}
design: {order: fixed}
trial: {duration_s: 1, start_timeout_s: 150}
"""
HELD_S = 2.0  # [s] the paused runner must start nothing for at least this long


def _events(out: Path) -> list[dict]:
    path = out / "study-log.jsonl"
    text = path.read_text() if path.exists() else ""
    return [json.loads(line) for line in text.splitlines() if line.endswith("}")]


def _wait(out: Path, runner: Child, timeout_s: float, **match: object) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if any(all(e.get(k) == v for k, v in match.items()) for e in _events(out)):
            return
        assert runner.running, runner.log.text()
        time.sleep(0.1)
    raise AssertionError(f"no {match} within {timeout_s} s: {runner.log.text()}")


def test_external_agent_and_pause(tmp_path: Path) -> None:
    study = tmp_path / "ext.yaml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    runner = start_child(["study", "run", str(study), "--out", str(out), "--backend", "sim"],
                         name="runner")  # fmt: skip
    agent: Child | None = None
    try:
        line = runner.wait_for_line(lambda text: "carlaverse study agent" in text, 60)
        assert line is not None and "P07 (cyclist, lab-b): run `" in line
        command = shlex.split(line.split("`")[1])
        assert command[:3] == ["carlaverse", "study", "agent"]
        agent = start_child(command[1:], name="agent P07")  # as the participant's lab would
        _wait(out, runner, 200, event="trial_live", trial="t01")
        control.send(out, "pause")
        _wait(out, runner, 60, event="trial_end", trial="t01")
        assert any(e["event"] == "paused" for e in _events(out))
        time.sleep(HELD_S)  # holding still is the behaviour under test: nothing may start
        assert not [e for e in _events(out) if e.get("trial") == "t02"]
        control.send(out, "resume")
        deadline = time.monotonic() + 200
        while runner.running and time.monotonic() < deadline:
            time.sleep(0.2)
        runner.finish_reading()
        assert runner.exit_code == 0, runner.log.text()
    finally:
        stop_children([runner, *([agent] if agent else [])])
    ends = [(e["trial"], e["outcome"]) for e in _events(out) if e["event"] == "trial_end"]
    assert ends == [("t01", "completed"), ("t02", "completed")]
    start = next(e for e in _events(out) if e["event"] == "trial_start" and e["trial"] == "t02")
    assert start["links"] == {"P07": {"delay_ms": 80.0, "jitter_ms": 0.0, "loss": 0.0}}
