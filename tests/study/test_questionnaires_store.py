"""The answers file: every set read back as written, a torn last line skipped, nothing lost
when the writing process is killed right after a store returns."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from carlaverse import messages as m
from carlaverse.study import questionnaires as q
from carlaverse.study.answers import (
    AnswerRecord,
    AnswerStore,
    Asked,
    answer_rows,
    latest_answers,
    read_answers,
)

REQUEST = q.ssq().request("t1")


def answers(seq: int, final: bool = False, **values: int) -> m.QuestionnaireAnswers:
    return m.QuestionnaireAnswers(m.SCHEMA_VERSION, REQUEST.request_id, "p01", seq, values, final)


def test_records_read_back_as_written_and_the_final_set_is_the_latest(tmp_path: Path) -> None:
    path = tmp_path / "study" / "answers.jsonl"
    with AnswerStore(path) as store:
        store.asked("p01", REQUEST)
        store.answered(REQUEST, answers(1, fatigue=1))
        store.answered(REQUEST, answers(2, fatigue=2, headache=1))
        store.answered(REQUEST, answers(3, True, fatigue=2, headache=1), {"total": 11.22})
        store.answered(REQUEST, answers(3, True, fatigue=2, headache=1))  # a repeat
    records, skipped = read_answers(path)
    assert skipped == 0 and isinstance(records[0], Asked) and records[0].request == REQUEST
    assert [r.seq for r in records if isinstance(r, AnswerRecord)] == [1, 2, 3, 3]
    best = latest_answers(records)[("p01", "t1.ssq")]
    assert best.final and best.scores == {"total": 11.22} and best.trial == "t1"
    assert best.answers == {"fatigue": 2, "headache": 1} and best.questionnaire == "ssq"


def test_without_a_final_set_the_newest_partial_one_is_kept(tmp_path: Path) -> None:
    path = tmp_path / "answers.jsonl"
    with AnswerStore(path) as store:
        store.answered(REQUEST, answers(1, fatigue=1))
        store.answered(REQUEST, answers(2, fatigue=3, burping=1))
    best = latest_answers(read_answers(path)[0])[("p01", "t1.ssq")]
    assert (best.final, best.answers) == (False, {"fatigue": 3, "burping": 1})


def test_a_line_cut_short_by_a_crash_is_skipped_and_counted(tmp_path: Path) -> None:
    path = tmp_path / "answers.jsonl"
    with AnswerStore(path) as store:
        store.answered(REQUEST, answers(1, fatigue=1))
    with open(path, "ab") as f:
        f.write(b'{"type":"answers","unix_s":1.0,"node_id":"p0')  # the crash, mid-write
    with AnswerStore(path) as store:  # a restarted runner appends after it
        store.answered(REQUEST, answers(2, fatigue=2))
    records, skipped = read_answers(path)
    # The torn line and the one appended to it form one undecodable line; the first stands.
    assert skipped == 1 and [r.seq for r in records] == [1]  # type: ignore[union-attr]


WRITER = """
import os, signal, sys
from carlaverse import messages as m
from carlaverse.study import questionnaires as q
from carlaverse.study.answers import AnswerStore
request = q.ssq().request("t1")
store = AnswerStore(sys.argv[1])
store.answered(request, m.QuestionnaireAnswers(3, "t1.ssq", "p01", 1, {"vertigo": 3}, True))
os.kill(os.getpid(), signal.SIGKILL)  # no close, no flush at exit: the store's write stands
"""


def test_a_process_killed_right_after_storing_loses_nothing(tmp_path: Path) -> None:
    path = tmp_path / "answers.jsonl"
    done = subprocess.run([sys.executable, "-c", WRITER, str(path)], timeout=60, check=False)
    assert done.returncode == -signal.SIGKILL
    (record,), skipped = read_answers(path)
    assert skipped == 0 and isinstance(record, AnswerRecord)
    assert record.answers == {"vertigo": 3} and record.final
    assert oct(os.stat(path).st_mode & 0o777) == "0o600"  # answers are personal data


def test_rows_for_an_export_hold_each_best_set_flat(tmp_path: Path) -> None:
    path = tmp_path / "answers.jsonl"
    tlx = q.nasa_tlx(weighted=False).request("t1")
    with AnswerStore(path) as store:
        store.asked("p01", REQUEST)
        store.answered(REQUEST, answers(1, fatigue=1))
        store.answered(tlx, m.QuestionnaireAnswers(3, tlx.request_id, "p02", 1, {"mental": 5}))
        store.answered(REQUEST, answers(2, True, fatigue=2), {"oculomotor": 15.16})
    rows = answer_rows(read_answers(path)[0])
    assert [(r["node_id"], r["request_id"], r["final"]) for r in rows] == [
        ("p01", "t1.ssq", True), ("p02", "t1.raw-tlx", False)]  # fmt: skip
    assert rows[0]["item.fatigue"] == 2 and rows[0]["score.oculomotor"] == 15.16
    assert rows[1]["item.mental"] == 5 and rows[1]["questionnaire"] == "raw-tlx"
