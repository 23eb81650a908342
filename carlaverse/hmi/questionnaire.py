"""A node's questionnaires: the study runner's request to the participant's pages, their
answers back over the fabric (issue 44; the messages and keys: carlaverse.messages).

    link = QuestionnaireLink(session, keys, node_id, hmi_server)   # while the node is joined
    ...
    link.close()

`QuestionnaireDesk` holds the state: the questionnaire shown now, the answers given so far,
and the final sets already sent (so a repeated request is answered with them again, not
shown twice). Requests arrive on a Zenoh callback thread and answers on the HMI's event
loop; both take the desk's lock for a few field updates only, and neither waits on the
network: what goes to the fabric is queued for the link's sender thread, what goes to the
pages is posted to the HMI server's loop.

Every request and answer from outside is validated: an undecodable request, an answer to
another questionnaire, an unknown item, a value off the scale, too long a text is counted
(`stats()`) and dropped, and the page is told why.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections import Counter, OrderedDict
from collections.abc import Callable
from typing import Any, Protocol

import zenoh

from carlaverse import messages as m
from carlaverse.hmi.wire import ENCODER, Answer, Questionnaire
from carlaverse.keys import Keys
from carlaverse.study.questionnaires import check_answers

log = logging.getLogger(__name__)

FINISHED_KEPT = 64  # final sets remembered per node, to answer a repeated request with


class Pages(Protocol):
    """Where the desk shows frames and whence answers come: the HMI server."""

    def post_frame(self, frame: bytes) -> None: ...
    def attach_questionnaires(self, desk: QuestionnaireDesk | None) -> None: ...


class QuestionnaireDesk:
    """The questionnaire a node's pages show now, and the answers they gave."""

    def __init__(self, node_id: str, send: Callable[[bytes], None]) -> None:
        self.node_id = node_id
        self._send = send  # an encoded QuestionnaireAnswers to the fabric; must not block
        self._pages: Pages | None = None
        self._lock = threading.Lock()
        self.current: m.QuestionnaireRequest | None = None
        self._answers: dict[str, int | str] = {}
        self._seq = 0
        self._submitted = False
        self._finished: OrderedDict[str, bytes] = OrderedDict()
        self.requests_shown = 0
        self.sets_sent = 0
        self.requests_dropped: Counter[str] = Counter()
        self.answers_rejected: Counter[str] = Counter()

    def show_on(self, pages: Pages | None) -> None:
        self._pages = pages

    # ------------------------------------------------------------ from the runner (fabric)

    def receive_request(self, payload: bytes) -> None:
        """A request from the fabric: shown, or answered with the final set it already has."""
        try:
            request = m.QUESTIONNAIRE_REQUEST.decode(payload)
        except m.MessageError as exc:
            self._drop_request("undecodable", exc)
            return
        with self._lock:
            final = self._finished.get(request.request_id)
            showing = self.current is not None and self.current.request_id == request.request_id
            if final is None and not showing:
                self._open(request)
                frame = self._frame()
        if final is not None:
            self._send(final)  # the runner missed it: repeat, never show again
        elif not showing:
            self.requests_shown += 1
            self._post(frame)

    def _open(self, request: m.QuestionnaireRequest) -> None:
        self.current, self._answers, self._seq, self._submitted = request, {}, 0, False

    def _drop_request(self, why: str, detail: object) -> None:
        self.requests_dropped[why] += 1
        if self.requests_dropped[why] == 1:
            log.warning("questionnaire request dropped (%s): %s", why, detail)

    # ------------------------------------------------------------ from the page (HMI loop)

    def answer(self, item: Answer) -> str:
        """The page's answers so far: sent on, or why not ("" when sent)."""
        with self._lock:
            why = self._refusal(item)
            if why:
                self.answers_rejected[why.split(":", 1)[0]] += 1
                return why
            self._seq += 1
            self._answers = dict(item.answers)
            payload = m.QUESTIONNAIRE_ANSWERS.encode(m.QuestionnaireAnswers(
                m.SCHEMA_VERSION, item.request_id, self.node_id, self._seq, self._answers,
                item.final,
            ))  # fmt: skip
            if item.final:
                self._submitted = True
                self._remember(item.request_id, payload)
            frame = self._frame() if item.final else None
        self._send(payload)
        self.sets_sent += 1
        if frame is not None:
            self._post(frame)  # every page of the node thanks and closes
        return ""

    def _refusal(self, item: Answer) -> str:
        if self.current is None or item.request_id != self.current.request_id:
            return f"questionnaire: {item.request_id!r} is not the questionnaire shown"
        if self._submitted:
            return "questionnaire: already submitted"
        problems = check_answers(self.current.items, item.answers, final=item.final)
        return f"answer: {'; '.join(problems)}" if problems else ""

    def _remember(self, request_id: str, payload: bytes) -> None:
        self._finished[request_id] = payload
        while len(self._finished) > FINISHED_KEPT:
            self._finished.popitem(last=False)

    # ------------------------------------------------------------ to the pages

    def page_frame(self) -> bytes | None:
        """What a page that connects now shows: the open questionnaire, or nothing."""
        with self._lock:
            return self._frame() if self.current is not None and not self._submitted else None

    def _frame(self) -> bytes:
        assert self.current is not None
        frame = Questionnaire(self.current, dict(self._answers), self._submitted)
        return ENCODER.encode(frame)

    def _post(self, frame: bytes) -> None:
        if self._pages is not None:
            self._pages.post_frame(frame)

    def stats(self) -> dict[str, Any]:
        return {
            "questionnaires_shown": self.requests_shown,
            "answer_sets_sent": self.sets_sent,
            "requests_dropped": dict(self.requests_dropped),
            "answers_rejected": dict(self.answers_rejected),
        }


class QuestionnaireLink:
    """Carries a desk's traffic on the node's Zenoh session: requests in on
    `study/<id>/ask`, answer sets out on `study/<id>/answers` from a sender thread."""

    def __init__(self, session: Any, keys: Keys, node_id: str, pages: Pages) -> None:
        self._outbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self.desk = QuestionnaireDesk(node_id, self._outbox.put)
        self._pages = pages
        self.send_errors = 0
        self._publisher = session.declare_publisher(
            keys.study(node_id, "answers"), congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )  # fmt: skip
        self._sender = threading.Thread(target=self._send_all, name="questionnaire-out",
                                        daemon=True)  # fmt: skip
        self._sender.start()
        pages.attach_questionnaires(self.desk)
        self._subscriber = session.declare_subscriber(
            keys.study(node_id, "ask"), lambda sample: self._receive(sample)
        )

    def _receive(self, sample: Any) -> None:
        try:  # a Zenoh callback: whatever goes wrong is counted, never raised into Zenoh
            self.desk.receive_request(sample.payload.to_bytes())
        except Exception as exc:
            self.desk._drop_request("error", exc)

    def _send_all(self) -> None:
        while (payload := self._outbox.get()) is not None:
            try:
                self._publisher.put(payload)
            except Exception as exc:  # a closing session: count it, keep the thread's loop
                self.send_errors += 1
                log.warning("questionnaire answers not sent: %s", exc)

    def close(self) -> None:
        """Stop taking requests, send what is queued, undeclare."""
        self._subscriber.undeclare()
        self._pages.attach_questionnaires(None)
        self.desk.show_on(None)
        self._outbox.put(None)
        self._sender.join(timeout=5)
        self._publisher.undeclare()
