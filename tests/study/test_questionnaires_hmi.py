"""Questionnaires answered by clicking on a real node's web HMI (`join drive --backend sim
--hmi 0`, in headless Chromium), asked and stored by the study runner's side over a real
fabric; the stored scores are the ones worked by hand, and killing the node loses nothing
that was answered: neither the sets submitted before nor the answers given so far to the
questionnaire it was showing (issue 44)."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Page

from carlaverse.keys import Keys
from carlaverse.shm import block_name
from carlaverse.study import questionnaires as q
from carlaverse.study.answers import AnswerRecord, AnswerStore, latest_answers, read_answers
from carlaverse.study.asking import QuestionnaireIncomplete, QuestionnaireRound
from carlaverse.transport.session import FabricSettings, open_session
from tests.browser import save_screenshot
from tests.hmi.live import node_with_hmi
from tests.support import Cluster, wait_until

pytestmark = pytest.mark.browser
KEYS = Keys("t")
# A node id of this run: another suite run on the machine may have a `p01` in session `t`.
NODE = f"p{os.getpid()}-drive"

# nausea 2 (N, D), headache 1 (O), vertigo 3 (D), the rest 0. By hand from Kennedy et al.'s
# table (tests/study/test_questionnaires.py): raw N 2, O 1, D 5; N 2 x 9.54 = 19.08,
# O 1 x 7.58 = 7.58, D 5 x 13.92 = 69.6, total (2 + 1 + 5) x 3.74 = 29.92.
SSQ_CLICKS = {"nausea": 2, "headache": 1, "vertigo": 3}
SSQ_SCORES = {"nausea": 19.08, "oculomotor": 7.58, "disorientation": 69.6, "total": 29.92}
# NASA-TLX ratings, and in each pair the subscale earlier in PREFERENCE picked: weights
# mental 5, effort 4, temporal 3, frustration 2, performance 1, physical 0.
# raw = (70 + 20 + 55 + 30 + 65 + 40) / 6 = 46.667;
# weighted = (5x70 + 0x20 + 3x55 + 1x30 + 4x65 + 2x40) / 15 = 885 / 15 = 59.
TLX_CLICKS = {"mental": 70, "physical": 20, "temporal": 55, "performance": 30, "effort": 65,
              "frustration": 40}  # fmt: skip
PREFERENCE = ["mental", "effort", "temporal", "frustration", "performance", "physical"]


@pytest.fixture(autouse=True)
def no_blocks_left() -> Iterator[None]:
    """A node killed by the test leaves its shared-memory blocks (its loop's state), which
    would stop a node of the same id from starting: remove them after each test."""
    yield
    for leftover in Path("/dev/shm").glob(f"{block_name(KEYS.session, NODE, '')}*"):
        leftover.unlink(missing_ok=True)


def runner_session(cluster: Cluster) -> Any:
    opened = open_session(FabricSettings(connect=[cluster.endpoint]),
                          deadline=time.monotonic() + 20)  # fmt: skip
    cluster.sessions.append(opened)
    return opened


def in_background(round_: QuestionnaireRound, timeout_s: float) -> dict[str, Any]:
    out: dict[str, Any] = {"stop": threading.Event()}

    def run() -> None:
        try:
            out["records"] = round_.run(timeout_s, out["stop"])
        except QuestionnaireIncomplete as exc:
            out["incomplete"] = exc

    out["thread"] = threading.Thread(target=run, daemon=True)
    out["thread"].start()
    return out


def click(page: Page, item: str, value: int) -> None:
    page.click(f'#questionnaire fieldset[data-item="{item}"] button[data-value="{value}"]')


def answer_tlx(page: Page) -> None:
    for subscale, rating in TLX_CLICKS.items():
        click(page, subscale, rating)
    for a, b in q.TLX_PAIRS:
        click(page, q.pair_item_id(a, b), 0 if PREFERENCE.index(a) < PREFERENCE.index(b) else 1)


def test_ssq_and_tlx_clicked_on_the_nodes_hmi_are_stored_scored_and_survive_a_kill(
    tmp_path: Path, page: Page, screenshot_dir: Path
) -> None:
    path = tmp_path / "answers.jsonl"
    store = AnswerStore(path)
    with node_with_hmi(tmp_path, "drive", NODE) as (cluster, node, url):
        runner = runner_session(cluster)
        page.goto(url + "dashboard")
        with QuestionnaireRound(runner, KEYS, store, [NODE], q.ssq(), "t1") as round_:
            run = in_background(round_, 90.0)
            page.wait_for_selector('#questionnaire[data-request="t1.ssq"]', timeout=30_000)
            assert page.is_disabled("#questionnaire .q-submit")  # nothing answered yet
            for symptom, _, _ in q.SSQ_SYMPTOMS:
                click(page, symptom, SSQ_CLICKS.get(symptom, 0))
            save_screenshot(page, screenshot_dir, "questionnaire-ssq")
            page.click("#questionnaire .q-submit")
            run["thread"].join(30)
        assert run["records"][NODE].scores == SSQ_SCORES
        page.wait_for_selector("#questionnaire.q-done")  # "Thank you"
        with QuestionnaireRound(runner, KEYS, store, [NODE], q.nasa_tlx(), "t1") as round_:
            run = in_background(round_, 90.0)
            page.wait_for_selector('#questionnaire[data-request="t1.nasa-tlx"]', timeout=30_000)
            answer_tlx(page)
            save_screenshot(page, screenshot_dir, "questionnaire-nasa-tlx")
            page.click("#questionnaire .q-submit")
            run["thread"].join(30)
        tlx = run["records"][NODE].scores
        assert tlx["raw_tlx"] == pytest.approx(280 / 6, abs=1e-4)
        assert tlx["weighted_tlx"] == pytest.approx(59.0)
        # The next trial's SSQ, answered in part; the page reloads; then the node is killed.
        with QuestionnaireRound(runner, KEYS, store, [NODE], q.ssq(), "t2") as round_:
            run = in_background(round_, 90.0)
            page.wait_for_selector('#questionnaire[data-request="t2.ssq"]', timeout=30_000)
            for symptom, value in SSQ_CLICKS.items():
                click(page, symptom, value)
            page.reload()  # the page goes away and comes back: what was clicked is still there
            pressed = '#questionnaire fieldset[data-item="vertigo"] button[aria-pressed="true"]'
            assert page.wait_for_selector(pressed).get_attribute("data-value") == "3"
            wait_until(lambda: stored(path, "t2.ssq").answers == SSQ_CLICKS, 15, "the partial set")
            node.stop(signal.SIGKILL)
            run["stop"].set()  # the operator gives up on this participant's questionnaire
            run["thread"].join(10)
        assert run["incomplete"].missing == [NODE]
        assert run["incomplete"].partial[NODE].answers == SSQ_CLICKS
    # What the file holds after the kill, read back: both final sets and the partial one.
    assert read_answers(path)[1] == 0
    ssq, tlx_set, partial = (stored(path, r) for r in ("t1.ssq", "t1.nasa-tlx", "t2.ssq"))
    assert ssq.final and ssq.scores == SSQ_SCORES
    assert ssq.answers == {s: SSQ_CLICKS.get(s, 0) for s, _, _ in q.SSQ_SYMPTOMS}
    assert tlx_set.final and tlx_set.scores["weighted_tlx"] == pytest.approx(59.0)
    assert not partial.final and partial.answers == SSQ_CLICKS
    assert not page.errors  # type: ignore[attr-defined]


def stored(path: Path, request_id: str) -> AnswerRecord:
    """The best set of `request_id` in the answers file, read back from disk."""
    best = latest_answers(read_answers(path)[0]).get((NODE, request_id))
    return best if best is not None else AnswerRecord(0, NODE, "", "", request_id, 0, False, {})
