"""The study export (issue 44.6) on a small study folder laid out as `carlaverse study run`
writes it: the study log written by the runner's own `StudyLog`, each completed trial's
recording by the recorder's own `McapSink` (poses on their real keys, a trigger event, an LSL
stream through `SharedSink` with the summary `StreamStats` writes), and the answers by the
runner's own `AnswerStore`. (Running the real runner takes minutes: tests/study/
test_study_e2e.py does that.)

Two participants meet head-on along the x axis in each trial: P01 (driver) accelerates from
rest-ish, P02 (cyclist) rides towards them at a constant speed, and the trial ends before
they meet, so every expected figure has a closed form (written beside each assertion):

    P01: x(t) = -60 + v0 t + a t²/2   (v0, a per condition)    P02: x(t) = X0 - u t

Trials: t01 practice (direct), t02 main (direct), t03 main (lagged): attempt 1 redone (no
recording under the trial's name), attempt 2 completed.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from pathlib import Path
from types import SimpleNamespace

import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest
from mcap.reader import make_reader

from carlaverse import messages as m
from carlaverse.cli import main
from carlaverse.keys import Keys, tile_of, tile_token
from carlaverse.study.answers import AnswerStore
from carlaverse.study.export import COLUMNS, export_study
from carlaverse.study.lsl_record import StreamStats
from carlaverse.study.lsl_sink import LslSample, SharedSink
from carlaverse.study.questionnaires import SSQ_SYMPTOMS, Questionnaire, nasa_tlx, score, ssq
from carlaverse.study.study_log import LOG_NAME, StudyLog, StudyLogError

pytestmark = pytest.mark.timeout(120)

STUDY = """
name: exp
participants:
  - {id: P01, role: driver, site: lab-a, kind: drive}
  - {id: P02, role: cyclist, site: lab-b, kind: bike}
conditions:
  - {id: direct}
  - id: lagged
    link: {delay_ms: 150, jitter_ms: 10}
design: {order: fixed, practice: [direct]}
"""
REAL_NAME = "Zelda Quimby-Marlowe"
DURATION_S = 6.0  # [s] of poses per trial
POSE_HZ = 50.0  # [Hz]
LSL_HZ = 100.0  # [Hz] nominal rate of the LSL stream
LENGTH_M = m.KIND_EXTENTS["other"].length  # neither ego says its kind: the analysis's default
# per trial: P01's speed at t=0 [m/s] and acceleration [m/s²], P02's start [m] and speed [m/s]
# they end 26-28 m apart: within the analysis's 30 m (`near_m`), its DRAC below 10 m/s²
MOTION = {"t01": (5.0, 1.0, 46.0, 5.0), "t02": (4.0, 2.0, 50.0, 4.0), "t03": (4.0, 1.0, 34.0, 4.0)}
CONDITION = {"t01": "direct", "t02": "direct", "t03": "lagged"}
LAGGED = {"delay_ms": 150.0, "jitter_ms": 10.0, "loss": 0.0}


# SSQ answers: nausea (loads on N and D) 2, headache (O) 1, the other 14 symptoms 0
def _ssq_ratings(**rated: int) -> dict[str, int | str]:
    """Every SSQ symptom rated 0 but those named."""
    return {key: rated.get(key, 0) for key, _, _ in SSQ_SYMPTOMS}


SSQ_ANSWERS = _ssq_ratings(nausea=2, headache=1)
# the raw TLX (Hart & Staveland 1988, unweighted): the mean of the six ratings, here 210 / 6
TLX_RATINGS = {"mental": 50, "physical": 20, "temporal": 30, "performance": 40, "effort": 60,
               "frustration": 10}  # fmt: skip


def _poses(trial: str, t0: float) -> dict[str, list[m.Pose]]:
    v0, a, x0, u = MOTION[trial]
    out: dict[str, list[m.Pose]] = {"P01": [], "P02": []}
    for k in range(int(DURATION_S * POSE_HZ) + 1):
        t = k / POSE_HZ
        out["P01"].append(m.Pose(k, t0 + t, -60.0 + v0 * t + a * t * t / 2, 0.0,
                                 vx=v0 + a * t, ax=a))  # fmt: skip
        out["P02"].append(m.Pose(k, t0 + t, x0 - u * t, 0.0, yaw=math.pi, vx=-u))
    return out


def _record(path: Path, session: str, trial: str, lsl_drop_every: int) -> None:
    """A trial's recording: both egos' poses, a trigger in t02, one LSL stream with every
    `lsl_drop_every`-th sample missing, and the stream's summary as the recorder writes it."""
    keys, wall0, t0 = Keys(session), time.time_ns(), 100.0
    sink = SharedSink(path, monotonic=time.monotonic)
    log_ns = lambda t: wall0 + round((t - t0) * 1e9)  # noqa: E731
    poses = _poses(trial, t0)
    for k in range(len(poses["P01"])):
        for pid, series in poses.items():
            p = series[k]
            sink.write(keys.pose(pid, tile_token(*tile_of(p.x, p.y))), m.POSE.encode(p),
                       log_ns(p.t))  # fmt: skip
    if trial == "t02":
        fired = m.TriggerFired(1, t0 + 2.5, "release", ["release waiting-car"], {"gap_m": 12.5})
        sink.write(keys.world("events"), m.WORLD_EVENT.encode(fired), log_ns(t0 + 2.5))
    stats = StreamStats("eeg", "lsl/eeg")
    channel = sink.add_lsl_channel("lsl/eeg", {})
    for k in range(int(DURATION_S * LSL_HZ)):
        if lsl_drop_every and k % lsl_drop_every == lsl_drop_every - 1:
            continue
        t = t0 + k / LSL_HZ
        sink.write_lsl(channel, LslSample(stats.samples, t, t, 0.0, [float(k)]), log_ns(t))
        stats.first_t = t if stats.samples == 0 else stats.first_t
        stats.last_t, stats.samples = t, stats.samples + 1
    sink.metadata("lsl/eeg", stats.as_metadata(SimpleNamespace(nominal_srate=lambda: LSL_HZ)))
    sink.close()


def _log_trial(
    log: StudyLog, out: Path, trial: str, attempt: int, outcome: str, note: str = ""
) -> None:
    kind, block = ("practice", 0) if trial == "t01" else ("main", 1)
    condition = CONDITION[trial]
    link = LAGGED if condition == "lagged" else {"delay_ms": 0.0, "jitter_ms": 0.0, "loss": 0.0}
    session = f"exp-abc123-{trial}-a{attempt}"
    log.append("trial_start", trial=trial, attempt=attempt, session=session, kind=kind,
               block=block, conditions={"P01": condition, "P02": condition},
               links={"P01": link, "P02": link}, scenario="none", seed=None,
               who={"P01": "driver", "P02": "cyclist"},
               recording=f"trials/{trial}.mcap")  # fmt: skip
    log.append("trial_live", trial=trial, attempt=attempt, session_t=100.0)
    if note:  # an operator's note during the trial (the runner logs it with the trial's id)
        log.append("note", trial=trial, text=note)
    if outcome == "completed":
        _record(out / "trials" / f"{trial}.mcap", session, trial, 10 if trial == "t03" else 0)
    figures = {"P01": {"P02": {"p50_m": 0.1, "p95_m": 0.3, "max_m": 0.5}}}
    log.append("trial_end", trial=trial, attempt=attempt, outcome=outcome,
               reason="operator's command" if outcome == "redo" else "",
               view_error=figures if outcome == "completed" else {})  # fmt: skip


def _answer(
    store: AnswerStore, trial: str, pid: str, answers: dict[str, int | str],
    form: Questionnaire | None = None,
) -> None:  # fmt: skip
    form = form or ssq()
    request = form.request(trial)
    store.asked(pid, request)
    scores = score(form, answers)  # what the runner stores with a final set
    store.answered(request, m.QuestionnaireAnswers(m.SCHEMA_VERSION, request.request_id, pid,
                                                   1, answers, True), scores)  # fmt: skip


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("study")
    (root / "study.yaml").write_text(STUDY)
    out = root / "out"
    (out / "trials").mkdir(parents=True)
    log = StudyLog(out / LOG_NAME)
    log.append("study", study="exp", digest="0" * 16, run_id="abc123", trials=3,
               participants={"P01": "driver", "P02": "cyclist"})  # fmt: skip
    (out / "trials" / "t02.scenario.yaml").write_text(
        "triggers:\n  - {id: release, when: 't > 2', actions: [release waiting-car]}\n"
        "  - {id: never, when: 'false', actions: [release other-car]}\n"
    )
    _log_trial(log, out, "t01", 1, "completed")
    _log_trial(log, out, "t02", 1, "completed")
    log.append("note", trial="", text="break: the cyclist asked for water")
    _log_trial(log, out, "t03", 1, "redo", note="P02 adjusted the seat")
    _log_trial(log, out, "t03", 2, "completed")
    with AnswerStore(out / "answers.jsonl") as store:
        _answer(store, "t02", "P01", SSQ_ANSWERS)
        _answer(store, "t03", "P01", _ssq_ratings(fatigue=3))
        _answer(store, "t02", "P02", dict(TLX_RATINGS), nasa_tlx(weighted=False))
    # a people file where a careless operator might leave it: in the run's folder itself
    (out / "people.yaml").write_text(f"P01: {REAL_NAME}\n")
    return root


@pytest.fixture(scope="module")
def exported(run_folder: Path) -> Path:
    dest = run_folder / "export"
    code = main(["study", "export", str(run_folder / "out"), "--to", str(dest), "--study",
                 str(run_folder / "study.yaml")])  # fmt: skip
    assert code == 0
    return dest


def _table(dest: Path, name: str) -> list[dict]:
    return pq.read_table(dest / f"{name}.parquet").to_pylist()


def _raw_distance(path: Path, node: str) -> float:
    """Path length from the recorded poses read with the plain MCAP reader (the `msg` view of
    the recording's JSON envelope), independent of the analysis's resampled tracks."""
    points = []
    with path.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            if f"/ego/{node}/pose/" in channel.topic:
                msg = json.loads(message.data)["msg"]
                points.append((msg["t"], msg["x"], msg["y"]))
    points.sort()
    return sum(math.dist(p[1:], q[1:]) for p, q in itertools.pairwise(points))


def test_every_table_is_written_as_parquet_and_csv_with_the_same_rows(exported: Path) -> None:
    documented = json.loads((exported / "columns.json").read_text())
    assert set(documented) == set(COLUMNS)
    for name, columns in documented.items():
        parquet = pq.read_table(exported / f"{name}.parquet")
        csv = pa_csv.read_csv(exported / f"{name}.csv")
        assert parquet.column_names == list(columns) == csv.column_names, name
        assert parquet.num_rows == csv.num_rows > 0, name
        for column in parquet.column_names:
            got, want = csv.column(column).to_pylist(), parquet.column(column).to_pylist()
            assert [_same(a, b) for a, b in zip(got, want, strict=True)] == [True] * len(want), (
                name, column, got, want)  # fmt: skip


def _same(a: object, b: object) -> bool:
    """CSV has no NaN: pyarrow writes it as an empty cell, which reads back as null."""
    if a is None and isinstance(b, float) and math.isnan(b):
        return True
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, rel=1e-12)
    return a == b or (a is None and b == "") or (a == "" and b is None)


def test_trials_list_every_attempt_per_participant_with_their_keys(exported: Path) -> None:
    rows = _table(exported, "trials")
    # 4 attempts (t01, t02, t03 x2) x 2 participants
    assert len(rows) == 8
    redo = [r for r in rows if r["trial"] == "t03" and r["attempt"] == 1]
    assert {r["outcome"] for r in redo} == {"redo"}
    redone = next(r for r in redo if r["participant"] == "P02")
    assert redone["notes"] == "P02 adjusted the seat"  # the note of the attempt it was made in
    lagged = next(r for r in rows if r["trial"] == "t03" and r["attempt"] == 2
                  and r["participant"] == "P02")  # fmt: skip
    assert (lagged["condition"], lagged["role"], lagged["site"]) == ("lagged", "cyclist", "lab-b")
    assert (lagged["delay_ms"], lagged["jitter_ms"]) == (150.0, 10.0)  # the study file's link
    assert lagged["notes"] == ""
    practice = [r for r in rows if r["trial"] == "t01"]
    assert all(r["practice"] and r["block"] == 0 for r in practice)
    p01 = next(r for r in rows if r["trial"] == "t02" and r["participant"] == "P01")
    assert p01["view_error_p95_m"] == 0.3


def test_trajectories_match_the_recorded_poses(run_folder: Path, exported: Path) -> None:
    rows = {(r["trial"], r["participant"]): r for r in _table(exported, "trajectories")}
    assert set(rows) == {(t, p) for t in ("t01", "t02", "t03") for p in ("P01", "P02")}
    for trial, (v0, a, _, u) in MOTION.items():
        driver, cyclist = rows[(trial, "P01")], rows[(trial, "P02")]
        recording = run_folder / "out" / "trials" / f"{trial}.mcap"
        assert driver["distance_m"] == pytest.approx(_raw_distance(recording, "P01"), abs=1e-6)
        # closed form: v0 T + a T²/2
        assert driver["distance_m"] == pytest.approx(v0 * DURATION_S + a * DURATION_S**2 / 2,
                                                     abs=1e-6)  # fmt: skip
        assert cyclist["distance_m"] == pytest.approx(u * DURATION_S, abs=1e-6)
        assert driver["max_speed_mps"] == pytest.approx(v0 + a * DURATION_S, abs=1e-6)
        # distance over time: (v0 T + a T²/2) / T
        assert driver["mean_speed_mps"] == pytest.approx(v0 + a * DURATION_S / 2, abs=1e-6)
        # the driver's node sends its acceleration, a; the cyclist's none, so theirs is
        # differentiated from a constant velocity: 0
        assert (driver["max_accel_mps2"], driver["accel_source"]) == (a, "sent")
        assert (cyclist["max_accel_mps2"], cyclist["accel_source"]) == (0.0, "differentiated")
        assert driver["p95_accel_mps2"] == a  # constant
        assert driver["samples"] == DURATION_S * POSE_HZ + 1
        assert driver["duration_s"] == pytest.approx(DURATION_S, abs=1e-6)
        assert driver["condition"] == CONDITION[trial]


def test_encounters_have_the_head_on_ttc_gap_and_drac(exported: Path) -> None:
    rows = [r for r in _table(exported, "encounters") if r["participant"] == "P01"]
    assert {r["trial"] for r in rows} == {"t01", "t02", "t03"}
    for r in rows:
        v0, a, x0, u = MOTION[r["trial"]]
        assert (r["other"], r["both_participants"], r["participant_involved"]) == (
            "P02", True, True)  # fmt: skip
        t = r["min_ttc_at_rel_s"]  # the worst grid instant: the last, as they close the whole time
        assert t == pytest.approx(DURATION_S, abs=0.11)
        # head-on, both footprints on the x axis: the gap is the centre distance less half
        # of each length; TTC = gap / closing speed
        gap = (x0 - u * t) - (-60.0 + v0 * t + a * t * t / 2) - LENGTH_M
        closing = v0 + a * t + u
        assert r["min_ttc_s"] == pytest.approx(gap / closing, rel=1e-6)
        assert r["min_gap_m"] == pytest.approx(gap, abs=1e-6)
        # DRAC (Almqvist 1991): closing speed² / (2 gap); within the friction limit here
        assert r["max_drac_mps2"] == pytest.approx(closing**2 / (2 * gap), rel=1e-6)
        assert not r["drac_implausible"] and not r["standstill"] and not r["contact"]
        assert math.isnan(r["min_pet_s"])  # head-on on one line: no crossing of paths
    # the pair has one row for each of its participants, each with their own keys
    p02 = [r for r in _table(exported, "encounters") if r["participant"] == "P02"]
    assert [(r["trial"], r["role"], r["other"]) for r in p02] == [
        ("t01", "cyclist", "P01"),
        ("t02", "cyclist", "P01"),
        ("t03", "cyclist", "P01"),
    ]


def test_triggers_say_which_fired_and_when(exported: Path) -> None:
    rows = {r["trigger_id"]: r for r in _table(exported, "triggers") if r["trial"] == "t02"}
    assert set(rows) == {"release", "never"}  # as the trial's scenario file lists them
    assert rows["release"]["fired"] and rows["release"]["times_fired"] == 1
    assert rows["release"]["first_fired_rel_s"] == pytest.approx(2.5, abs=1e-6)
    assert json.loads(rows["release"]["values"]) == {"gap_m": 12.5}
    assert not rows["never"]["fired"] and math.isnan(rows["never"]["first_fired_rel_s"])


def test_questionnaire_scores_match_the_published_ssq_weights(exported: Path) -> None:
    rows = _table(exported, "questionnaires")
    scores = {(r["trial"], r["measure"]): r["value"] for r in rows
              if r["measure_kind"] == "score" and r["participant"] == "P01"}  # fmt: skip
    # t02 by hand (Kennedy et al. 1993): nausea loads N and D, headache O: raw N=2, O=1, D=2;
    # N = 2 x 9.54, O = 1 x 7.58, D = 2 x 13.92, total = (2 + 1 + 2) x 3.74
    assert scores[("t02", "nausea")] == pytest.approx(19.08)
    assert scores[("t02", "oculomotor")] == pytest.approx(7.58)
    assert scores[("t02", "disorientation")] == pytest.approx(27.84)
    assert scores[("t02", "total")] == pytest.approx(18.70)
    # t03: fatigue (O) 3: total = 3 x 3.74
    assert scores[("t03", "total")] == pytest.approx(11.22)
    tlx = next(r for r in rows if r["questionnaire"] == "raw-tlx" and r["measure"] == "raw_tlx")
    assert (tlx["participant"], tlx["condition"], tlx["value"]) == ("P02", "direct", 35.0)
    item = next(r for r in rows if r["trial"] == "t02" and r["measure"] == "nausea"
                and r["measure_kind"] == "item")  # fmt: skip
    assert (item["value"], item["condition"], item["role"]) == (2.0, "direct", "driver")


def test_lsl_coverage_is_the_sample_count_over_the_nominal_rate(exported: Path) -> None:
    rows = {r["trial"]: r for r in _table(exported, "lsl")}
    assert set(rows) == {"t01", "t02", "t03"}
    full = rows["t02"]
    assert full["samples"] == full["samples_in_file"] == int(DURATION_S * LSL_HZ)
    assert full["coverage"] == pytest.approx(1.0)
    gappy = rows["t03"]  # every 10th sample dropped: 540 of 600
    assert gappy["samples_in_file"] == gappy["samples"] == 540
    # coverage = samples / ((last - first) x rate + 1); the last kept sample is k = 598
    assert gappy["coverage"] == pytest.approx(540 / (598 + 1), rel=1e-9)


def test_the_report_is_self_contained_and_says_what_is_left_out(exported: Path) -> None:
    page = (exported / "report.html").read_text()
    assert "http://" not in page and "https://" not in page and "<script" not in page
    assert page.count("data:image/png;base64,") == 2  # min TTC and SSQ total by condition
    assert "Practice trials (t01)" in page
    assert "trial t03 attempt 1: redo" in page  # the redone attempt, and why it is not measured
    assert "lagged" in page and "direct" in page
    assert "break: the cyclist asked for water" in page  # a note between trials
    # the summary's direct row: SSQ total 18.70 (P01, t02) and raw TLX 35.00 (P02, t02)
    assert "<td>18.70</td><td>35.00</td>" in page
    assert "trial t03 attempt 1: redo" in (exported / "README.md").read_text()


def test_no_export_file_names_a_person(run_folder: Path, exported: Path) -> None:
    files = sorted(p for p in exported.iterdir() if p.is_file())
    assert len(files) == 6 * 2 + 3
    for path in files:
        text = path.read_bytes().decode("utf-8", errors="replace")
        if path.suffix == ".parquet":  # its pages are compressed: look at the values
            text = json.dumps(pq.read_table(path).to_pylist(), default=str)
        assert REAL_NAME not in text and "Zelda" not in text, path.name
    assert "P01" in (exported / "trials.csv").read_text()  # the search sees pseudonyms


def test_a_folder_without_a_log_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["study", "export", str(tmp_path)]) == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and str(tmp_path) in said[0] and "study-log.jsonl" in said[0]


def test_a_log_naming_a_person_is_not_exported(tmp_path: Path) -> None:
    """A hand-edited log with a name where a pseudonym belongs is refused, naming the file."""
    out = tmp_path / "out"
    out.mkdir()
    StudyLog(out / LOG_NAME).append("study", study="exp", digest="0" * 16, run_id="abc123",
                                    trials=1, participants={"Zelda": "driver"})  # fmt: skip
    with pytest.raises(StudyLogError, match="'Zelda' is not a pseudonym"):
        export_study(out, tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_answers_from_an_unknown_node_are_left_out_without_its_id(
    run_folder: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    (out / "trials").mkdir(parents=True)
    (out / LOG_NAME).write_bytes((run_folder / "out" / LOG_NAME).read_bytes())
    with AnswerStore(out / "answers.jsonl") as store:
        _answer(store, "t02", "Zelda", SSQ_ANSWERS)
    done = export_study(out, tmp_path / "x")
    assert done.tables["questionnaires"] == []
    assert any("answers to 't02.ssq' from a node" in line for line in done.excluded)
    assert "Zelda" not in (tmp_path / "x" / "README.md").read_text()


def test_export_without_the_study_file_leaves_the_site_empty(
    run_folder: Path, tmp_path: Path
) -> None:
    done = export_study(run_folder / "out", tmp_path / "x")
    assert {r["site"] for r in done.tables["trials"]} == {""}
