"""Questionnaires over a real fabric (a router, Zenoh sessions on 127.0.0.1): the runner's
request reaches the node's desk, answers come back, are vetted, stored and scored; forged
or malformed sets are counted and dropped, never raised."""

from __future__ import annotations

import json
import os
import threading
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from carlaverse import messages as m
from carlaverse.hmi.questionnaire import QuestionnaireDesk, QuestionnaireLink
from carlaverse.hmi.wire import Answer
from carlaverse.keys import Keys
from carlaverse.study import questionnaires as q
from carlaverse.study.answers import AnswerStore, latest_answers, read_answers
from carlaverse.study.asking import (
    QuestionnaireIncomplete,
    QuestionnaireRound,
    QuestionnaireTimeout,
)
from carlaverse.transport.session import FabricSettings, open_session
from tests.hmi.live import node_with_hmi
from tests.support import Cluster, wait_until

KEYS = Keys("t")


class Pages:
    """The HMI server's part the desk talks to: frames kept for the test."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []
        self.desk: QuestionnaireDesk | None = None

    def post_frame(self, frame: bytes) -> None:
        self.frames.append(frame)

    def attach_questionnaires(self, desk: QuestionnaireDesk | None) -> None:
        self.desk = desk
        if desk is not None:
            desk.show_on(self)


def session(cluster: Cluster) -> Any:
    opened = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(opened)
    return opened


@pytest.fixture
def fabric(cluster: Cluster) -> Iterator[tuple[Cluster, QuestionnaireLink, Pages]]:
    cluster.router()
    pages = Pages()
    link = QuestionnaireLink(session(cluster), KEYS, "p01", pages)
    try:
        yield cluster, link, pages
    finally:
        link.close()


def in_background(round_: QuestionnaireRound, timeout_s: float) -> dict[str, Any]:
    out: dict[str, Any] = {"stop": threading.Event()}

    def run() -> None:
        try:
            out["records"] = round_.run(timeout_s, out["stop"])
        except QuestionnaireTimeout as exc:
            out["timeout"] = exc
        except QuestionnaireIncomplete as exc:
            out["incomplete"] = exc

    out["thread"] = threading.Thread(target=run, daemon=True)
    out["thread"].start()
    return out


def test_answers_travel_back_and_are_stored_with_their_scores(fabric, tmp_path: Path) -> None:
    cluster, link, pages = fabric
    desk = link.desk
    store = AnswerStore(tmp_path / "answers.jsonl")
    with QuestionnaireRound(session(cluster), KEYS, store, ["p01"], q.ssq(), "t1") as round_:
        run = in_background(round_, 30.0)
        wait_until(lambda: desk.current is not None, 15, "the request at the node")
        assert pages.frames and b'"type":"questionnaire"' in pages.frames[0]
        assert desk.answer(Answer("t1.ssq", {"nausea": 2})) == ""  # a partial set
        wait_until(lambda: "p01" in round_.latest, 10, "the partial set at the runner")
        answers = {s: 0 for s, _, _ in q.SSQ_SYMPTOMS} | {"nausea": 2, "headache": 1, "vertigo": 3}
        assert desk.answer(Answer("t1.ssq", answers, final=True)) == ""
        run["thread"].join(15)
    record = run["records"]["p01"]
    # nausea 2 (N, D), headache 1 (O), vertigo 3 (D): see test_questionnaires.py
    assert record.scores == {"nausea": 19.08, "oculomotor": 7.58, "disorientation": 69.6,
                             "total": 29.92}  # fmt: skip
    assert b'"submitted":true' in pages.frames[-1]
    records, skipped = read_answers(tmp_path / "answers.jsonl")
    assert skipped == 0 and latest_answers(records)[("p01", "t1.ssq")] == record
    assert [(r.seq, r.final) for r in records[1:]] == [(1, False), (2, True)]  # type: ignore[union-attr]
    assert desk.requests_shown == 1  # the repeats of the request showed it once


def test_a_repeated_request_after_the_final_set_gets_it_again_not_a_new_showing(
    fabric, tmp_path: Path
) -> None:
    cluster, link, _ = fabric
    desk = link.desk
    answers = {k: 5 * i for i, k in enumerate(q.TLX_IDS)}
    store = AnswerStore(tmp_path / "first.jsonl")
    with QuestionnaireRound(session(cluster), KEYS, store, ["p01"], q.nasa_tlx(False), "t2") as r:
        run = in_background(r, 30.0)
        wait_until(lambda: desk.current is not None, 15, "the request at the node")
        assert desk.answer(Answer("t2.raw-tlx", answers, final=True)) == ""
        run["thread"].join(15)
    # The runner crashed before it stored the final set; restarted, it asks again.
    store = AnswerStore(tmp_path / "again.jsonl")
    with QuestionnaireRound(session(cluster), KEYS, store, ["p01"], q.nasa_tlx(False), "t2") as r:
        again = r.run(15.0)["p01"]
    assert again.answers == answers and again.final and desk.requests_shown == 1
    assert again.scores["raw_tlx"] == pytest.approx((0 + 5 + 10 + 15 + 20 + 25) / 6, abs=1e-4)


def test_forged_and_malformed_answer_sets_are_counted_and_dropped(fabric, tmp_path: Path) -> None:
    cluster, link, _ = fabric
    forger = session(cluster)
    key = KEYS.study("p01", "answers")
    store = AnswerStore(tmp_path / "answers.jsonl")

    def forged(**fields: Any) -> bytes:
        base = dict(schema=m.SCHEMA_VERSION, request_id="t3.ssq", node_id="p01", seq=1,
                    answers={"fatigue": 1}, final=False)  # fmt: skip
        return m.QUESTIONNAIRE_ANSWERS.encode(m.QuestionnaireAnswers(**(base | fields)))

    bad = [
        b"\xc1 not msgpack",  # undecodable
        forged(answers={"fatigue": 7}),  # off the 0-3 scale
        forged(answers={"not_a_symptom": 1}),  # unknown item
        forged(answers={"fatigue": "x" * 100}),  # text where a rating goes
        forged(node_id="p02"),  # another node's set on p01's key
        forged(request_id="t9.ssq"),  # another questionnaire
        forged(final=True),  # a final set missing 15 required items
    ]
    with QuestionnaireRound(session(cluster), KEYS, store, ["p01"], q.ssq(), "t3") as round_:
        run = in_background(round_, 4.0)
        wait_until(lambda: link.desk.current is not None, 15, "the request at the node")
        for payload in bad:
            forger.put(key, payload)
        wait_until(lambda: sum(round_.rejected.values()) == len(bad), 10, "every forgery counted")
        run["thread"].join(10)
    assert round_.rejected == {"undecodable": 1, "answers": 4, "node": 1, "request": 1}
    assert isinstance(run["timeout"], QuestionnaireTimeout) and run["timeout"].missing == ["p01"]
    records, _ = read_answers(tmp_path / "answers.jsonl")
    assert len(records) == 1  # the `asked` line only: nothing forged was stored


def test_the_desk_refuses_bad_page_answers_and_bad_requests_naming_why() -> None:
    sent: list[bytes] = []
    desk = QuestionnaireDesk("p01", sent.append)
    desk.receive_request(b"\x93 garbage")
    assert desk.requests_dropped == {"undecodable": 1} and desk.current is None
    desk.receive_request(m.QUESTIONNAIRE_REQUEST.encode(q.ssq().request("t4")))
    assert desk.answer(Answer("t5.ssq", {"fatigue": 1})).startswith("questionnaire: 't5.ssq'")
    assert desk.answer(Answer("t4.ssq", {"fatigue": 9})) == (
        "answer: item 'fatigue': 9 is off the scale 0..3 step 1")  # fmt: skip
    assert desk.answer(Answer("t4.ssq", {"fatigue": 1}, final=True)).startswith(
        "answer: item 'general_discomfort': required")  # fmt: skip
    assert desk.answers_rejected == {"questionnaire": 1, "answer": 2} and not sent


def test_a_walk_node_without_pages_of_its_own_serves_the_questionnaire(tmp_path: Path) -> None:
    """`join walk --hmi 0`: the walker has no dashboard, its HMI is the questionnaire page."""
    node_id = f"w{os.getpid()}"
    with node_with_hmi(tmp_path, "walk", node_id) as (cluster, node, url):
        assert f"HMI at {url}questionnaire" in "".join(node.stderr)  # its home page
        with urllib.request.urlopen(url + "questionnaire", timeout=10) as page:
            assert b"No questionnaire is open" in page.read()
        store = AnswerStore(tmp_path / "answers.jsonl")
        with QuestionnaireRound(session(cluster), KEYS, store, [node_id], q.ssq(), "t5") as r:
            run = in_background(r, 30.0)
            wait_until(lambda: status(url).get("questionnaires_shown") == 1, 20, "the SSQ shown")
            run["stop"].set()
            run["thread"].join(10)
            node.stop()  # SIGINT: the node leaves and prints its summary
    assert run["incomplete"].missing == [node_id]
    # The node's exit summary counts it too (after the link let go of the HMI).
    assert node.json()["extra"]["hmi"]["questionnaires_shown"] == 1


def status(url: str) -> dict[str, Any]:
    with urllib.request.urlopen(url + "api/status", timeout=10) as response:
        return json.loads(response.read())  # type: ignore[no-any-return]
