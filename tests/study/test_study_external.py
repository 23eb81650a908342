"""An externally launched study: the runner says what each participant's machine runs, the
participant's agent is started apart (as a lab would, from the printed line), the operator's
pause holds the next trial until `resume`, and each trial ends when its world says so (a
scenario trigger's event, put here on the trial session's `world/events`) long before its
120 s duration."""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.procs import Child, free_port, stop_children
from carlaverse.procs import start as start_child
from carlaverse.study import control
from carlaverse.transport.session import FabricSettings, open_session

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
trial: {duration_s: 120, start_timeout_s: 150, end_on_triggers: [crossed]}
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


def _session_of(out: Path, trial: str, attempt: int) -> str:
    return next(e["session"] for e in _events(out) if e["event"] == "trial_start"
                and e["trial"] == trial and e["attempt"] == attempt)  # fmt: skip


def _fire_trigger(endpoint: str, out: Path, trial: str, attempt: int = 1) -> None:
    """What the authority puts when a scenario trigger fires, into the trial's session, until
    the log shows the trial's attempt ended."""
    event = m.TriggerFired(seq=1, t=42.0, trigger_id="crossed", actions=[])
    key = Keys(_session_of(out, trial, attempt)).world("events")
    fabric = open_session(FabricSettings(mode="client", connect=[endpoint]))
    deadline = time.monotonic() + 60
    try:
        while not any(e["event"] == "trial_end" and e["trial"] == trial
                      and e["attempt"] == attempt for e in _events(out)):  # fmt: skip
            assert time.monotonic() < deadline, f"{trial} did not end on its trigger"
            fabric.put(key, m.WORLD_EVENT.encode(event))
            time.sleep(0.2)
    finally:
        fabric.close()


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
        endpoint = next(a for a in command if a.startswith("tcp/"))
        control.send(out, "pause")
        _fire_trigger(endpoint, out, "t01")
        assert any(e["event"] == "paused" for e in _events(out))
        time.sleep(HELD_S)  # holding still is the behaviour under test: nothing may start
        assert not [e for e in _events(out) if e.get("trial") == "t02"]
        control.send(out, "resume")
        _wait(out, runner, 200, event="trial_live", trial="t02")
        _fire_trigger(endpoint, out, "t02")
        runner.wait_exit(200)
        assert runner.exit_code == 0, runner.log.text()
    finally:
        stop_children([runner, *([agent] if agent else [])])
    ends = [(e["trial"], e["outcome"], e["reason"]) for e in _events(out)
            if e["event"] == "trial_end"]  # fmt: skip
    assert [(t, o) for t, o, _ in ends] == [("t01", "completed"), ("t02", "completed")]
    assert all(r == "trigger crossed fired at session time 42.000 s" for _, _, r in ends)
    start = next(e for e in _events(out) if e["event"] == "trial_start" and e["trial"] == "t02")
    assert start["links"] == {"P07": {"delay_ms": 80.0, "jitter_ms": 0.0, "loss": 0.0}}


def test_missing_roles_are_named_and_the_run_ends_5(tmp_path: Path) -> None:
    study = tmp_path / "ext.yaml"
    study.write_text(STUDY.replace("start_timeout_s: 150", "start_timeout_s: 2"))
    out = tmp_path / "out"
    runner = start_child(["study", "run", str(study), "--out", str(out)], name="runner")
    try:  # nobody starts P07's agent
        runner.wait_exit(120)
    finally:
        stop_children([runner])
    assert runner.exit_code == 5, runner.log.text()  # Exit.NOT_ADMITTED
    (end,) = [e for e in _events(out) if e["event"] == "trial_end"]
    assert (end["trial"], end["outcome"]) == ("t01", "not_started")
    assert end["reason"] == "not present within 2 s: P07 (cyclist)"
    assert "run again with --out" in runner.log.text()
    assert list((out / "trials").glob("t01.attempt1.not_started.mcap"))


def test_abort_ends_the_run_and_a_rerun_goes_on_with_the_same_agent(tmp_path: Path) -> None:
    # link_port fixed: a lab's participant machine keeps its agent pointed at one address
    port = free_port()
    study = tmp_path / "ext.yaml"
    study.write_text(STUDY.replace("kind: bike}", f"kind: bike, link_port: {port}}}"))
    out = tmp_path / "out"
    argv = ["study", "run", str(study), "--out", str(out), "--backend", "sim"]
    agent = start_child(["study", "agent", "--study", "ext", "--participant", "P07",
                         "--connect", f"tcp/127.0.0.1:{port}"], name="agent P07")  # fmt: skip
    first = start_child(argv, name="runner 1")
    second: Child | None = None
    try:
        _wait(out, first, 200, event="trial_live", trial="t01")
        control.send(out, "abort")
        first.proc.wait(timeout=120)
        assert first.proc.returncode == 1, first.log.text()  # Exit.FAILED: work left undone
        second = start_child(argv, name="runner 2")
        endpoint = f"tcp/127.0.0.1:{port}"
        for trial in ("t01", "t02"):
            attempt = 2 if trial == "t01" else 1
            _wait(out, second, 200, event="trial_live", trial=trial, attempt=attempt)
            _fire_trigger(endpoint, out, trial, attempt)
        second.proc.wait(timeout=120)
        assert second.proc.returncode == 0, second.log.text()
    finally:
        stop_children([c for c in (first, second, agent) if c is not None])
    ends = [(e["trial"], e["attempt"], e["outcome"]) for e in _events(out)
            if e["event"] == "trial_end"]  # fmt: skip
    assert ends == [("t01", 1, "aborted"), ("t01", 2, "completed"), ("t02", 1, "completed")]
    assert (out / "trials" / "t01.attempt1.aborted.mcap").is_file()
