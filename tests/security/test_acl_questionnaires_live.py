"""Questionnaires under the roster's access control, with real routers, certificates and
Zenoh sessions (issue 44): the study runner at site `b` asks the drive node at site `a` and
gets its answers; a participant can neither read another's questionnaire or answers nor
forge them. Each negative check is ordered behind a positive one from the same session (see
test_acl_live.py): once the legitimate message arrived, a forgery let through would have too.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.hmi.questionnaire import QuestionnaireDesk, QuestionnaireLink
from carlaverse.hmi.wire import Answer
from carlaverse.keys import Keys
from carlaverse.study import questionnaires as q
from carlaverse.study.answers import AnswerStore
from carlaverse.study.asking import QuestionnaireRound
from tests.security.lab import SESSION, Inbox, Lab
from tests.support import wait_until

K = Keys(SESSION)
NODES = [
    ("authority", "authority", "a"),
    ("a-drive", "drive", "a"),
    ("b-bike", "bike", "b"),
    ("runner", "study-runner", "b"),
]
RATINGS = dict.fromkeys(q.TLX_IDS, 50)


class Pages:
    def post_frame(self, frame: bytes) -> None:
        pass

    def attach_questionnaires(self, desk: QuestionnaireDesk | None) -> None:
        pass


@pytest.fixture
def lab(tmp_path: Path) -> Iterator[Lab]:
    lab = Lab(tmp_path, NODES)
    lab.write()
    lab.router("a")
    lab.router("b")
    try:
        yield lab
    finally:
        lab.close()


def ask(round_: QuestionnaireRound) -> dict[str, object]:
    out: dict[str, object] = {}
    thread = threading.Thread(target=lambda: out.update(round_.run(30.0)), daemon=True)
    thread.start()
    out["thread"] = thread
    return out


def test_the_runner_asks_across_sites_and_no_participant_reads_or_forges_another(
    lab: Lab, tmp_path: Path
) -> None:
    drive, bike, runner = (lab.node(n, s) for n, _, s in NODES[1:])
    spy, heard = Inbox(), Inbox()
    # b-bike's identity on a session of its own: a session hears its own puts locally, and
    # the forgeries below must be judged by what the router delivers.
    lab.node("b-bike", "b").declare_subscriber(K.subtree("study"), spy)  # all of study/**
    runner.declare_subscriber(K.subtree("study"), heard)
    drive_link = QuestionnaireLink(drive, K, "a-drive", Pages())
    bike_link = QuestionnaireLink(bike, K, "b-bike", Pages())
    store = AnswerStore(tmp_path / "answers.jsonl")
    tlx = q.nasa_tlx(weighted=False)
    try:
        with QuestionnaireRound(runner, K, store, ["a-drive"], tlx, "t1") as round_:
            run = ask(round_)
            wait_until(lambda: drive_link.desk.current is not None, 20, "the ask at a-drive")
            assert drive_link.desk.answer(Answer("t1.raw-tlx", RATINGS, final=True)) == ""
            run["thread"].join(20)  # type: ignore[attr-defined]
        assert run["a-drive"].scores["raw_tlx"] == 50.0  # type: ignore[attr-defined]
        # b-bike forges a-drive's answers and an ask to a-drive, then answers its own.
        forged = m.QuestionnaireAnswers(m.SCHEMA_VERSION, "t1.raw-tlx", "a-drive", 9,
                                        dict.fromkeys(q.TLX_IDS, 100), True)  # fmt: skip
        bike.put(K.study("a-drive", "answers"), m.QUESTIONNAIRE_ANSWERS.encode(forged))
        bike.put(K.study("a-drive", "ask"), m.QUESTIONNAIRE_REQUEST.encode(q.ssq().request("x")))
        with QuestionnaireRound(runner, K, store, ["b-bike"], tlx, "t2") as round_:
            run = ask(round_)
            wait_until(lambda: bike_link.desk.current is not None, 20, "the ask at b-bike")
            assert bike_link.desk.answer(Answer("t2.raw-tlx", RATINGS, final=True)) == ""
            run["thread"].join(20)  # type: ignore[attr-defined]
        assert run["b-bike"].final  # type: ignore[attr-defined]
        own = {K.study("b-bike", "ask"), K.study("b-bike", "answers")}
        wait_until(lambda: own <= {k for k, _ in spy.items}, 10, "b-bike's own study keys")
    finally:
        drive_link.close()
        bike_link.close()
    assert {k for k, _ in spy.items} == own  # nothing of a-drive's reached b-bike
    forged_bytes = m.QUESTIONNAIRE_ANSWERS.encode(forged)
    assert forged_bytes not in heard.payloads(K.study("a-drive", "answers"))  # never carried
    assert drive_link.desk.requests_shown == 1  # the forged ask never reached a-drive
