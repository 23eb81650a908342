"""The study runner's side of questionnaires: ask participants' nodes, store what they answer.

    with AnswerStore(out / "answers.jsonl") as store:
        records = ask_all(session, Keys("lab"), store, ["p01-drive", "p02-bike"], ssq(), "t3",
                          timeout_s=600)
        records["p01-drive"].scores    # {"nausea": 9.54, "oculomotor": 0.0, ...}

Each node's HMI shows the questionnaire (carlaverse.hmi.questionnaire) and sends the answers
given so far on every change; every set that arrives is checked against the items asked and
stored (fsynced) before the next is read, the final one with its scores. The request is
repeated every `repeat_s` until the node's final set arrives, so a node that joins late,
restarts, or missed the request still shows it, and one that sent its final set already
sends it again. A set that does not decode, names another node or questionnaire, or holds
an unknown item, a value off the scale or too long a text is counted (`rejected`) and
dropped. At the deadline `QuestionnaireTimeout` (a TimeoutError), on a stop
`QuestionnaireStopped` (both `QuestionnaireIncomplete`) carries the partial sets.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable
from typing import Any

import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys, check_token
from carlaverse.study.answers import AnswerRecord, AnswerStore
from carlaverse.study.questionnaires import Questionnaire, check_answers, score

log = logging.getLogger(__name__)

REPEAT_S = 1.0  # [s] between repeats of a request not yet answered in full
STOP_POLL_S = 0.2  # [s] longest wait before a stop is seen


class QuestionnaireIncomplete(Exception):
    """Some nodes sent no final set; `partial` holds the newest set of each of them that sent
    any (stored too), `missing` the nodes without a final set."""

    def __init__(self, missing: list[str], partial: dict[str, AnswerRecord], why: str) -> None:
        super().__init__(f"no final answers from {missing} {why} "
                         f"(partial sets from {sorted(partial)})")  # fmt: skip
        self.missing = missing
        self.partial = partial


class QuestionnaireTimeout(QuestionnaireIncomplete, TimeoutError):
    """The deadline passed first."""


class QuestionnaireStopped(QuestionnaireIncomplete):
    """The runner was stopped first (its `stop` event)."""


class QuestionnaireRound:
    """One questionnaire asked of several nodes at once, until each has answered in full."""

    def __init__(
        self, session: Any, keys: Keys, store: AnswerStore, node_ids: Iterable[str],
        questionnaire: Questionnaire, trial: str, clock: Callable[[], float] = time.monotonic,
        repeat_s: float = REPEAT_S,
    ) -> None:  # fmt: skip
        self.questionnaire = questionnaire
        self.request = questionnaire.request(trial)
        self._payload = m.QUESTIONNAIRE_REQUEST.encode(self.request)
        self.store, self.clock, self.repeat_s = store, clock, repeat_s
        self.rejected: Counter[str] = Counter()
        self.latest: dict[str, AnswerRecord] = {}
        self.final: dict[str, AnswerRecord] = {}
        self._inbox: queue.SimpleQueue[tuple[str, bytes]] = queue.SimpleQueue()
        self._publishers: dict[str, Any] = {}
        self._subscribers: list[Any] = []
        nodes = [check_token(node_id) for node_id in node_ids]  # all, before declaring any
        for node_id in nodes:
            self._open(session, keys, node_id)

    def _open(self, session: Any, keys: Keys, node_id: str) -> None:
        def receive(sample: Any) -> None:  # a Zenoh callback: hand over, decode on our side
            self._inbox.put((node_id, sample.payload.to_bytes()))

        self._subscribers.append(
            session.declare_subscriber(keys.study(node_id, "answers"), receive)
        )
        self._publishers[node_id] = session.declare_publisher(
            keys.study(node_id, "ask"), congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )  # fmt: skip
        self.store.asked(node_id, self.request)

    def run(self, timeout_s: float, stop: threading.Event | None = None) -> dict[str, AnswerRecord]:
        """Ask until every node sent its final set (returned, by node id), `timeout_s` passes
        (QuestionnaireTimeout) or `stop` is set (QuestionnaireStopped, within STOP_POLL_S).
        Every set received is stored as it arrives."""
        deadline = self.clock() + timeout_s
        next_ask = self.clock()
        while len(self.final) < len(self._publishers):
            now = self.clock()
            if now >= deadline:
                raise QuestionnaireTimeout(*self._incomplete(), "before the deadline")
            if stop is not None and stop.is_set():
                raise QuestionnaireStopped(*self._incomplete(), "before the runner stopped")
            if now >= next_ask:
                self._ask_waiting()
                next_ask = now + self.repeat_s
            self._take(min(next_ask, deadline, now + STOP_POLL_S) - now)
        return dict(self.final)

    def _incomplete(self) -> tuple[list[str], dict[str, AnswerRecord]]:
        missing = sorted(set(self._publishers) - set(self.final))
        return missing, {n: self.latest[n] for n in missing if n in self.latest}

    def _ask_waiting(self) -> None:
        for node_id, publisher in self._publishers.items():
            if node_id not in self.final:
                publisher.put(self._payload)

    def _take(self, wait_s: float) -> None:
        try:
            node_id, payload = self._inbox.get(timeout=max(wait_s, 0.0))
        except queue.Empty:
            return
        answers, why = self._vet(node_id, payload)
        scores = self._scores(answers) if answers is not None and answers.final else {}
        if answers is None or scores is None:
            why = why or "answers: the final set cannot be scored"
            self.rejected[why.split(":", 1)[0]] += 1
            if self.rejected[why.split(":", 1)[0]] == 1:
                log.warning("answers from %s dropped: %s", node_id, why)
            return
        if node_id in self.final:
            return  # a repeat of the final set: stored once
        record = self.store.answered(self.request, answers, scores)
        self.latest[node_id] = record
        if answers.final:
            self.final[node_id] = record

    def _vet(self, node_id: str, payload: bytes) -> tuple[m.QuestionnaireAnswers | None, str]:
        """The answers and "", or None and why they are dropped."""
        try:
            answers = m.QUESTIONNAIRE_ANSWERS.decode(payload)
        except m.MessageError as exc:
            return None, f"undecodable: {exc}"
        if answers.node_id != node_id:
            return None, f"node: {answers.node_id!r} sent on {node_id!r}'s key"
        if answers.request_id != self.request.request_id:
            return None, f"request: {answers.request_id!r} is not {self.request.request_id!r}"
        problems = check_answers(self.request.items, answers.answers, final=answers.final)
        if problems:
            return None, f"answers: {'; '.join(problems)}"
        return answers, ""

    def _scores(self, answers: m.QuestionnaireAnswers) -> dict[str, float] | None:
        try:
            return score(self.questionnaire, answers.answers)
        except ValueError as exc:  # checked already; a scorer's own rule, counted by the caller
            log.warning("final answers from %s cannot be scored: %s", answers.node_id, exc)
            return None

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()
        for publisher in self._publishers.values():
            publisher.undeclare()
        self._subscribers, self._publishers = [], {}

    def __enter__(self) -> QuestionnaireRound:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def ask_all(
    session: Any, keys: Keys, store: AnswerStore, node_ids: Iterable[str],
    questionnaire: Questionnaire, trial: str, timeout_s: float,
    stop: threading.Event | None = None,
) -> dict[str, AnswerRecord]:  # fmt: skip
    """Ask each node `questionnaire` for `trial`; their final sets by node id."""
    with QuestionnaireRound(session, keys, store, node_ids, questionnaire, trial) as round_:
        return round_.run(timeout_s, stop)


def ask(
    session: Any, keys: Keys, store: AnswerStore, node_id: str,
    questionnaire: Questionnaire, trial: str, timeout_s: float,
    stop: threading.Event | None = None,
) -> AnswerRecord:  # fmt: skip
    """Ask one node; its final set, stored and scored."""
    return ask_all(session, keys, store, [node_id], questionnaire, trial, timeout_s, stop)[node_id]
