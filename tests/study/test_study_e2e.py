"""Issue 44 items 1, 2, 5, 7 and 8, the acceptance run: a two-participant, four-trial study with
two conditions counterbalanced (a balanced Latin square over two blocks), run end to end
headless on sim devices; after each trial both participants answer the SSQ by clicking on their
own node's web HMI in headless Chromium; a real LSL outlet streams a synthetic ECG at 250 Hz
for the whole run; the runner is killed outright (SIGKILL) in the middle of a trial and run
again to completion, during which the operator has a trial redone and notes something; then
`carlaverse study export`. The tables are checked against the recordings, read with the plain
`mcap` reader:

- every completed trial has both participants' SSQ, scored as worked by hand below;
- the lsl table's sample count of each completed trial is what its MCAP holds on the ECG's
  channel, and its coverage is ~1 (the outlet never paused);
- each trajectory's distance is the sum of the steps between the poses in the MCAP;
- the killed trial is logged `killed` and redone as attempt 2; no completed trial runs twice;
- an operator's note lands in the log with its trial, and `redo` reruns the trial at once;
- each completed trial has its recording, whose metadata holds the trial's conditions and the
  link each participant had; the lagged participant's link delay is what the file says;
- each trial's report gives, per participant, the view error of the other against the truth;
- the pseudonym -> person mapping reaches neither the log, nor any recording (searched in the
  decompressed records), nor the tables, while the pseudonyms themselves do;
- `study status` tells the same story from the log;
- the processes the killed runner left are stopped by the next run.

(This one run used to be two tests, this and test_study_run.py's kill/resume/redo run, which
started the same runner, agents and nodes and killed and resumed them the same way.)
"""

from __future__ import annotations

import contextlib
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
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Message, Metadata
from mcap.stream_reader import StreamReader
from playwright.sync_api import Page

from carlaverse.procs import Child, free_port, stop_children
from carlaverse.procs import start as start_child
from carlaverse.study import control
from carlaverse.study.leftovers import CHILDREN_NAME
from carlaverse.study.status import run_status
from carlaverse.study.trial_sink import WITHHELD
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
    link: {{delay_ms: {lagged_delay_ms}, jitter_ms: 10}}
design: {{order: latin, blocks: 2}}
trial: {{duration_s: 2.0, start_timeout_s: 150, view_probe_hz: 10}}
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
PEOPLE = {"P01": "Zelda Quimby-Marlowe", "P02": "Ignatius Blorfendorf"}
LAGGED_DELAY_MS = 150.0
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


def _wait_for(
    out: Path, event: str, trial: str, attempt: int, runner: Child, timeout_s: float = 240
) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if any(e["event"] == event and e.get("trial") == trial
               and e.get("attempt") == attempt for e in _events(out)):  # fmt: skip
            return
        assert runner.running, f"the runner exited ({runner.exit_code}): {runner.log.text()}"
        time.sleep(0.1)
    raise AssertionError(f"no {event} of {trial}/{attempt}: {runner.log.text()}")


def _send(out: Path, command: str) -> None:
    """What `carlaverse study control OUT COMMAND` does (test_study_cli runs the command),
    in-process so it lands within the short trial; then wait until the runner took it."""
    control.send(out, command)
    deadline = time.monotonic() + 30
    while control.pending(out):
        assert time.monotonic() < deadline, f"the runner did not take {command}"
        time.sleep(0.05)


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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    return state != "Z"


def _write_study(tmp_path: Path) -> tuple[Path, Path]:
    """The study file and the private pseudonym -> person mapping beside it."""
    study = tmp_path / "study" / "e2e.yaml"
    study.parent.mkdir()
    study.write_text(STUDY.format(p01_hmi=free_port(), p02_hmi=free_port(), ecg=ECG,
                                  lagged_delay_ms=LAGGED_DELAY_MS,
                                  session_id=NETWORK.session_id))  # fmt: skip
    people = tmp_path / "private" / "people.yaml"
    people.parent.mkdir()
    people.write_text("".join(f"{k}: {v}\n" for k, v in PEOPLE.items()))
    people.chmod(0o600)
    return study, people


def _run_killed_and_resumed(page: Page, argv: list[str], out: Path) -> list[int]:
    """Runner 1 until t02 is live, then SIGKILLed; runner 2 to the end, the operator having
    t03 redone and noting something during its second attempt. The pids runner 1 left."""
    first = start_child(argv, name="runner 1")
    try:
        _answer_ssq(page, first, out, "t01", 1)
        _wait_for(out, "trial_live", "t02", 1, first)
        left_by_first = [e["pid"] for e in json.loads((out / CHILDREN_NAME).read_text())]
        os.kill(first.proc.pid, signal.SIGKILL)  # a crash mid-trial: no cleanup at all
        first.proc.wait()
    finally:
        stop_children([first])
    second = start_child(argv, name="runner 2")
    try:
        _answer_ssq(page, second, out, "t02", 2)
        _wait_for(out, "trial_live", "t03", 1, second)
        _send(out, "redo")
        _wait_for(out, "trial_start", "t03", 2, second, 60)
        _send(out, "note P02 sneezed")
        for trial, attempt in (("t03", 2), ("t04", 1)):
            _answer_ssq(page, second, out, trial, attempt)
        second.wait_exit(120)
        assert second.exit_code == 0, second.log.text()
    finally:
        stop_children([second])
    return left_by_first


def _export(study: Path, out: Path, export: Path) -> None:
    exported = start_child(["study", "export", str(out), "--to", str(export),
                            "--study", str(study)], name="export")  # fmt: skip
    try:
        exported.proc.wait(120)
        exported.finish_reading()
        assert exported.exit_code == 0, exported.log.text()
    finally:
        stop_children([exported])


def test_two_participants_four_trials_killed_resumed_answered_recorded_exported(
    tmp_path: Path, page: Page
) -> None:
    began = time.monotonic()
    study, people = _write_study(tmp_path)
    out, export = tmp_path / "out", tmp_path / "export"
    argv = ["study", "run", str(study), "--out", str(out), "--people", str(people)]
    with ecg_outlet():
        left_by_first = _run_killed_and_resumed(page, argv, out)
    _export(study, out, export)

    completed = _check_the_log(out)
    _check_recordings(out)
    _check_the_tables(out, export, completed)
    _check_privacy(out, export)
    _check_status(out)
    # The killed run's router, authority and agents were stopped by the second run.
    assert not [pid for pid in left_by_first if _alive(pid)]
    assert not (out / CHILDREN_NAME).exists()
    print(f"e2e acceptance run: {time.monotonic() - began:.1f} s")


def _check_the_log(out: Path) -> dict[str, int]:
    """The killed trial is redone, so is the one the operator asked; no completed trial ran
    twice; each completed trial has its SSQ and its view error figures. Completed trial ->
    its attempt."""
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
    asked = [(e["trial"], e["attempt"], e["questionnaire"], e["missing"])
             for e in events if e["event"] == "questionnaire"]  # fmt: skip
    assert asked == [(t, a, "ssq", []) for t, a, o in ends if o == "completed"]

    # Counterbalanced: Williams rows for two conditions are (direct, lagged), (lagged, direct).
    conditions = {e["trial"]: e["conditions"] for e in events if e["event"] == "trial_start"}
    assert [conditions[t]["P01"] for t in ("t01", "t02", "t03", "t04")] == [
        "direct", "lagged", "direct", "lagged"]  # fmt: skip
    assert [conditions[t]["P02"] for t in ("t01", "t02", "t03", "t04")] == [
        "lagged", "direct", "lagged", "direct"]  # fmt: skip

    for end in (e for e in events if e["event"] == "trial_end" and e["outcome"] == "completed"):
        figures = end["view_error"]
        assert set(figures) == {"P01", "P02"}, end
        assert figures["P01"]["P02"]["samples"] > 0 and figures["P02"]["P01"]["samples"] > 0
        for seen in (figures["P01"]["P02"], figures["P02"]["P01"]):
            assert 0.0 <= seen["p50_m"] <= seen["p95_m"] <= seen["max_m"]
    return {t: a for t, a, o in ends if o == "completed"}


def _check_recordings(out: Path) -> None:
    """One file per attempt, named by its outcome; a trial's metadata holds its conditions
    and each participant's link."""
    trials = out / "trials"
    assert sorted(p.name for p in trials.glob("*.mcap")) == [
        "t01.mcap", "t02.attempt1.killed.mcap", "t02.mcap", "t03.attempt1.redo.mcap",
        "t03.mcap", "t04.mcap"]  # fmt: skip
    meta = _all_metadata(trials / "t01.mcap", "carlaverse.study.trial")[0]
    assert json.loads(meta["conditions"]) == {"P01": "direct", "P02": "lagged"}
    links = json.loads(meta["links"])
    assert links["P02"]["delay_ms"] == LAGGED_DELAY_MS and links["P01"]["delay_ms"] == 0.0


def _check_the_tables(out: Path, export: Path, completed: dict[str, int]) -> None:
    """The export's tables against the log, the hand-worked SSQ scores and the recordings."""
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


def _check_privacy(out: Path, export: Path) -> None:
    """The names appear nowhere the study wrote; the pseudonyms do."""
    trials = out / "trials"
    written = [(out / "study-log.jsonl").read_text()]
    written += [_mcap_text(p) for p in trials.glob("*.mcap")]
    written += [p.read_text() for p in trials.glob("*.yaml")]
    written += [p.read_text() for p in export.glob("*.csv")]
    everything = "\n".join(written)
    for person in PEOPLE.values():
        for word in person.split():
            assert word not in everything
    assert "P01" in _mcap_text(trials / "t03.mcap") and "P02" in everything
    # Pseudonyms only, in every table.
    for name in ("trials", "trajectories", "questionnaires"):
        assert {r["participant"] for r in _table(export, name)} <= {"P01", "P02"}
    # what the participants' machines are called is withheld, keyed by pseudonym still
    records = _all_metadata(trials / "t03.mcap", "carlaverse.hostnames")  # one per refresh
    assert {pid for hosts in records for pid in hosts} >= {"P01", "P02"}
    assert {value for hosts in records for value in hosts.values()} == {WITHHELD}


def _check_status(out: Path) -> None:
    """`study status` tells the same story from the log."""
    status = run_status(out)
    assert (status.state, status.completed) == ("ended", 4)
    assert [(r.trial, r.attempts, r.outcome) for r in status.trials] == [
        ("t01", 1, "completed"), ("t02", 2, "completed"), ("t03", 2, "completed"),
        ("t04", 1, "completed")]  # fmt: skip
    assert status.trials[2].notes == ["P02 sneezed"]
    assert status.trials[1].recording == "trials/t02.mcap"
    assert set(status.trials[0].view_p95_m) == {"P01>P02", "P02>P01"}
