"""Issue 44 item 8, the acceptance run: a two-participant, four-trial study with two conditions
counterbalanced (a balanced Latin square over two blocks), run end to end headless on sim
devices; after each trial both participants answer the SSQ by clicking on their own node's
web HMI in headless Chromium; a real LSL outlet streams a synthetic ECG at 250 Hz for the
whole run; the runner is killed outright (SIGKILL) in the middle of a trial and run again to
completion; then `carlaverse study export`. The tables are checked against the recordings,
read with the plain `mcap` reader:

- every completed trial has both participants' SSQ, scored as worked by hand below;
- the lsl table's sample count of each completed trial is what its MCAP holds on the ECG's
  channel, and its coverage is ~1 (the outlet never paused);
- each trajectory's distance is the sum of the steps between the poses in the MCAP;
- the killed trial is redone as attempt 2 and no completed trial is run twice;
- the tables name participants by pseudonym only.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import re
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from mcap.reader import make_reader
from playwright.sync_api import Page

from carlaverse.procs import Child, free_port, stop_children
from carlaverse.procs import start as start_child
from tests.study.lsl_support import NETWORK, ecg_mv, lsl

pytestmark = [pytest.mark.browser, pytest.mark.timeout(600)]

ECG = f"ecg-e2e-{os.getpid()}"
ECG_RATE_HZ = 250.0
STUDY = """
name: e2e-accept
launch: local
participants:
  - {{id: P01, role: driver, site: lab-a, kind: drive, hmi_port: {p01_hmi}}}
  - {{id: P02, role: cyclist, site: lab-b, kind: bike, hmi_port: {p02_hmi}}}
conditions:
  - {{id: direct}}
  - id: lagged
    link: {{delay_ms: 100, jitter_ms: 10}}
design: {{order: latin, blocks: 2}}
trial: {{duration_s: 2.0, start_timeout_s: 150, view_probe_hz: 5}}
questionnaires: {{after_trial: [ssq], timeout_s: 120}}
lsl: {{streams: [{ecg}], session_id: {session_id}, wait_s: 30}}
"""

# What each participant clicks (symptom -> severity 0..3; every other symptom 0), and the
# scores worked by hand from Kennedy et al. (1993), Table 1 and its weights: a symptom counts
# in each subscale it is marked for; raw sums times N 9.54, O 7.58, D 13.92; total = (raw N +
# raw O + raw D) x 3.74.
#   P01: nausea 2 (N, D), headache 1 (O), vertigo 3 (D): raw N 2, O 1, D 5;
#        N 19.08, O 7.58, D 69.6, total 8 x 3.74 = 29.92.
#   P02: fatigue 2 (O), sweating 1 (N), blurred vision 1 (O, D): raw N 1, O 3, D 1;
#        N 9.54, O 22.74, D 13.92, total 5 x 3.74 = 18.7.
CLICKS = {
    "P01": {"nausea": 2, "headache": 1, "vertigo": 3},
    "P02": {"fatigue": 2, "sweating": 1, "blurred_vision": 1},
}
SCORES = {
    "P01": {"nausea": 19.08, "oculomotor": 7.58, "disorientation": 69.6, "total": 29.92},
    "P02": {"nausea": 9.54, "oculomotor": 22.74, "disorientation": 13.92, "total": 18.7},
}
# The 16 items of the SSQ (Kennedy et al. 1993), as the HMI names them.
SYMPTOMS = ("general_discomfort", "fatigue", "headache", "eyestrain", "difficulty_focusing",
            "increased_salivation", "sweating", "nausea", "difficulty_concentrating",
            "fullness_of_head", "blurred_vision", "dizzy_eyes_open", "dizzy_eyes_closed",
            "vertigo", "stomach_awareness", "burping")  # fmt: skip
HMI_URL = re.compile(r"(P0[12]): HMI at (http://127\.0\.0\.1:\d+/\S*)")


@contextmanager
def ecg_outlet() -> Iterator[None]:
    """A synthetic ECG at 250 Hz on a real LSL outlet, pushed in real time (chunks of 10,
    paced by LSL's clock) until the block ends."""
    pylsl = lsl()
    info = pylsl.StreamInfo(ECG, "ECG", 1, ECG_RATE_HZ, "float32", f"e2e-{ECG}")
    outlet = pylsl.StreamOutlet(info)
    stop = threading.Event()

    def push() -> None:
        t0, i = pylsl.local_clock(), 0
        while not stop.is_set():
            due = t0 + (i + 10) / ECG_RATE_HZ
            while pylsl.local_clock() < due and not stop.is_set():
                time.sleep(0.005)
            for k in range(i, i + 10):
                t = t0 + k / ECG_RATE_HZ
                outlet.push_sample([ecg_mv(t - t0)], t)
            i += 10

    thread = threading.Thread(target=push, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(5)


def _events(out: Path) -> list[dict]:
    path = out / "study-log.jsonl"
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.endswith("}")]


def _wait_for(out: Path, event: str, trial: str, attempt: int, runner: Child) -> None:
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline:
        if any(e["event"] == event and e.get("trial") == trial
               and e.get("attempt") == attempt for e in _events(out)):  # fmt: skip
            return
        assert runner.running, f"the runner exited ({runner.exit_code}): {runner.log.text()}"
        time.sleep(0.1)
    raise AssertionError(f"no {event} of {trial}/{attempt}: {runner.log.text()}")


def _hmi_urls(runner: Child) -> dict[str, str]:
    """Each participant's HMI page, as their agent relayed it to the runner's console."""
    return {pid: url for pid, url in HMI_URL.findall(runner.log.text())}


def _answer_ssq(page: Page, runner: Child, out: Path, trial: str, attempt: int) -> None:
    """Once the trial is live, each participant's page opens; the SSQ shows there when the
    trial's live phase ends; it is clicked through and submitted."""
    _wait_for(out, "trial_live", trial, attempt, runner)
    for pid in ("P01", "P02"):
        deadline = time.monotonic() + 60
        while pid not in _hmi_urls(runner):
            assert time.monotonic() < deadline, f"no HMI URL of {pid}: {runner.log.text()}"
            time.sleep(0.1)
        page.goto(_hmi_urls(runner)[pid])
        page.wait_for_selector(f'#questionnaire[data-request="{trial}.ssq"]', timeout=90_000)
        for symptom in SYMPTOMS:
            value = CLICKS[pid].get(symptom, 0)
            page.click(f'#questionnaire fieldset[data-item="{symptom}"] '
                       f'button[data-value="{value}"]')  # fmt: skip
        page.click("#questionnaire .q-submit")
        page.wait_for_selector("#questionnaire.q-done")


def _table(folder: Path, name: str) -> list[dict[str, str]]:
    with (folder / f"{name}.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def _mcap_messages(path: Path) -> dict[str, list[dict]]:
    """topic -> the `msg` of each message, with the plain mcap reader (recording envelope:
    JSON {"msg": the message as an object, "raw": ...})."""
    found: dict[str, list[dict]] = {}
    with path.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            wanted = channel.topic.startswith("lsl/") or "/ego/" in channel.topic
            if wanted and message.data:
                found.setdefault(channel.topic, []).append(json.loads(message.data)["msg"])
    return found


def _distance(poses: list[dict]) -> float:
    """Path length: straight steps between consecutive poses in time order, one per instant."""
    first: dict[float, dict] = {}
    for pose in poses:
        first.setdefault(pose["t"], pose)
    steps = itertools.pairwise(first[t] for t in sorted(first))
    return sum(math.hypot(b["x"] - a["x"], b["y"] - a["y"]) for a, b in steps)


def test_two_participants_four_trials_killed_resumed_answered_recorded_exported(
    tmp_path: Path, page: Page
) -> None:
    began = time.monotonic()
    study = tmp_path / "study" / "e2e.yaml"
    study.parent.mkdir()
    study.write_text(STUDY.format(p01_hmi=free_port(), p02_hmi=free_port(), ecg=ECG,
                                  session_id=NETWORK.session_id))  # fmt: skip
    out = tmp_path / "out"
    argv = ["study", "run", str(study), "--out", str(out)]
    with ecg_outlet():
        first = start_child(argv, name="runner 1")
        try:
            _answer_ssq(page, first, out, "t01", 1)
            _wait_for(out, "trial_live", "t02", 1, first)
            os.kill(first.proc.pid, signal.SIGKILL)  # a crash mid-trial: no cleanup at all
            first.proc.wait()
        finally:
            stop_children([first])
        second = start_child(argv, name="runner 2")
        try:
            for trial, attempt in (("t02", 2), ("t03", 1), ("t04", 1)):
                _answer_ssq(page, second, out, trial, attempt)
            deadline = time.monotonic() + 120
            while second.running and time.monotonic() < deadline:
                time.sleep(0.1)
            second.finish_reading()
            assert second.exit_code == 0, second.log.text()
        finally:
            stop_children([second])
    export = tmp_path / "export"
    exported = start_child(["study", "export", str(out), "--to", str(export),
                            "--study", str(study)], name="export")  # fmt: skip
    try:
        exported.proc.wait(120)
        exported.finish_reading()
        assert exported.exit_code == 0, exported.log.text()
    finally:
        stop_children([exported])

    # The killed trial is redone; no completed trial ran twice.
    events = _events(out)
    ends = [(e["trial"], e["attempt"], e["outcome"]) for e in events if e["event"] == "trial_end"]
    assert ends == [("t01", 1, "completed"), ("t02", 1, "killed"), ("t02", 2, "completed"),
                    ("t03", 1, "completed"), ("t04", 1, "completed")]  # fmt: skip
    asked = [(e["trial"], e["attempt"], e["questionnaire"], e["missing"])
             for e in events if e["event"] == "questionnaire"]  # fmt: skip
    assert asked == [(t, a, "ssq", []) for t, a, o in ends if o == "completed"]
    completed = {t: a for t, a, o in ends if o == "completed"}

    # Counterbalanced: Williams rows for two conditions are (direct, lagged), (lagged, direct).
    trials = _table(export, "trials")
    conditions = {(r["trial"], r["participant"]): r["condition"] for r in trials}
    assert [conditions[(t, "P01")] for t in ("t01", "t02", "t03", "t04")] == [
        "direct", "lagged", "direct", "lagged"]  # fmt: skip
    assert [conditions[(t, "P02")] for t in ("t01", "t02", "t03", "t04")] == [
        "lagged", "direct", "lagged", "direct"]  # fmt: skip

    # Every completed trial's SSQ, from both participants, with the scores worked by hand.
    scores: dict[tuple[str, str], dict[str, float]] = {}
    for row in _table(export, "questionnaires"):
        if row["measure_kind"] == "score":
            assert row["final"] == "true", row
            scores.setdefault((row["trial"], row["participant"]), {})[row["measure"]] = float(
                row["value"]
            )
    assert set(scores) == {(t, p) for t in completed for p in ("P01", "P02")}
    for (_, pid), got in scores.items():
        assert got == pytest.approx(SCORES[pid], abs=1e-6)

    # Each completed trial's recording against the lsl and trajectories tables.
    lsl_rows = {r["trial"]: r for r in _table(export, "lsl")}
    paths = {(r["trial"], r["participant"]): r for r in _table(export, "trajectories")}
    assert set(lsl_rows) == set(completed)
    for trial, attempt in completed.items():
        assert lsl_rows[trial]["attempt"] == str(attempt)
        recorded = _mcap_messages(out / "trials" / f"{trial}.mcap")
        ecg = recorded[f"lsl/{ECG}"]
        row = lsl_rows[trial]
        assert row["stream"] == ECG
        assert int(row["samples"]) == int(row["samples_in_file"]) == len(ecg)
        # The trial's recording spans at least its 2 s live phase and both questionnaires.
        assert len(ecg) >= 2.0 * ECG_RATE_HZ, len(ecg)
        assert float(row["coverage"]) == pytest.approx(1.0, abs=0.02)
        assert [s["seq"] for s in ecg] == list(range(len(ecg)))
        for pid in ("P01", "P02"):
            poses = [p for topic, msgs in recorded.items() if f"/ego/{pid}/pose" in topic
                     for p in msgs]  # fmt: skip
            assert poses, f"{trial}: no poses of {pid}"
            assert float(paths[(trial, pid)]["distance_m"]) == pytest.approx(
                _distance(poses), rel=1e-9, abs=1e-9
            )

    # Pseudonyms only, in every table.
    for name in ("trials", "trajectories", "questionnaires"):
        assert {r["participant"] for r in _table(export, name)} <= {"P01", "P02"}
    print(f"e2e acceptance run: {time.monotonic() - began:.1f} s")
