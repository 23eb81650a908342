"""What the HMI's pages and the node say to each other over the WebSocket (JSON text frames).

This is a local link between a node and the pages it serves, not a fabric message, so it is
not in carlaverse.messages (whose keys and schema docs/protocol.md describes).

Page → node, each validated by `InputCheck` (a bad one is counted and dropped, and the page
is told why in a `rejected` frame):

    {"type": "press", "action": "low_beam"}       a touchscreen tap (the node's actions)
    {"type": "cruise", "command": "set"}          set | resume | cancel
    {"type": "ping", "page_ms": 1234.5}           clock sync: the page's performance.now()
    {"type": "answer", "request_id": "t1.ssq", "answers": {"fatigue": 1}, "final": false}
                                                  a questionnaire's answers so far; `final`
                                                  when the participant submits

Node → page: `info` once on connect, then `telemetry` at the configured rate, `message` when
text is pushed (`HmiServer.show_message`), `pong` for each ping, `rejected` for bad input,
`questionnaire` when the study runner asks the node's participant one (and again to a page
that connects while it is open, and once submitted), carrying the answers given so far.
"""

from __future__ import annotations

from collections import Counter
from typing import Annotated, Any, Literal

import msgspec

from carlaverse.messages import (
    QUESTIONNAIRE_MAX_ITEMS,
    LongText,
    QuestionnaireRequest,
    ScaleValue,
    StudyId,
)
from carlaverse.patterns import anchored

Finite = Annotated[float, msgspec.Meta(ge=-1e12, le=1e12)]  # JSON has no NaN; bounds it too
ActionName = Annotated[str, msgspec.Meta(pattern=anchored(r"[a-z0-9_]{1,32}"))]
MAX_INPUT_BYTES = 1024  # a page's input is a few dozen bytes; anything longer is not ours
MAX_ANSWER_BYTES = 48 * 1024  # but answers: up to 64 items, a few texts of 2000 characters


class Press(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="press", tag_field="type"):
    action: ActionName


class Cruise(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="cruise", tag_field="type"
):
    command: Literal["set", "resume", "cancel"]


class Ping(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="ping", tag_field="type"):
    page_ms: Finite  # [ms] the page's performance.now() when it sent this


class Answer(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="answer", tag_field="type"
):
    request_id: StudyId
    answers: Annotated[
        dict[StudyId, ScaleValue | LongText], msgspec.Meta(max_length=QUESTIONNAIRE_MAX_ITEMS)
    ]
    final: bool = False


PageInput = Press | Cruise | Ping | Answer
Command = Press | Cruise  # what reaches the node; pings are answered by the server


class Info(msgspec.Struct, frozen=True, tag="info", tag_field="type"):
    kind: str  # node kind: drive, bike
    node_id: str
    units: str
    rate_hz: float
    actions: list[str]  # the presses the node takes
    cruise: bool  # the node takes cruise commands
    static: dict[str, Any]  # per kind, e.g. redline_rpm


class Telemetry(msgspec.Struct, frozen=True, tag="telemetry", tag_field="type"):
    seq: int
    stamp_s: float  # [s] monotonic clock of the node's host when its loop produced this state
    values: dict[str, Any]


class Message(msgspec.Struct, frozen=True, tag="message", tag_field="type"):
    id: int
    text: str
    seconds: float  # [s] how long the page shows it


class Pong(msgspec.Struct, frozen=True, tag="pong", tag_field="type"):
    page_ms: float  # echoed from the ping
    node_s: float  # [s] the node host's monotonic clock when it answered


class Questionnaire(msgspec.Struct, frozen=True, tag="questionnaire", tag_field="type"):
    request: QuestionnaireRequest
    answers: dict[str, int | str]  # given so far (a page that reloads shows them again)
    submitted: bool  # the node has sent the final set: the page thanks and closes


class Rejected(msgspec.Struct, frozen=True, tag="rejected", tag_field="type"):
    reason: str


ENCODER = msgspec.json.Encoder()


class InputCheck:
    """Decode and vet page input: the node's own action list and cruise support.

    `rejected` counts drops by reason (`json`, `schema`, `size`, `binary`, `action`,
    `cruise`); `accepted` counts the rest. Answers are checked against their questionnaire
    by the node's QuestionnaireDesk (carlaverse.hmi.questionnaire).
    """

    def __init__(self, actions: frozenset[str], cruise: bool) -> None:
        self.actions = actions
        self.cruise = cruise
        self._decoder = msgspec.json.Decoder(PageInput)
        self._envelope = msgspec.json.Decoder(_Envelope)
        self.accepted = 0
        self.rejected: Counter[str] = Counter()

    def check(self, raw: str | bytes | None) -> tuple[PageInput | None, str]:
        """The input and "", or None and why it was dropped (also counted)."""
        item, reason = self._vet(raw)
        if item is None:
            self.rejected[reason.split(":", 1)[0]] += 1
        else:
            self.accepted += 1
        return item, reason

    def _vet(self, raw: str | bytes | None) -> tuple[PageInput | None, str]:
        if not isinstance(raw, str):
            return None, "binary: send JSON text frames"
        limit = MAX_ANSWER_BYTES if self._is_answer(raw) else MAX_INPUT_BYTES
        if len(raw) > limit:
            return None, f"size: {len(raw)} bytes > {limit}"
        try:
            item = self._decoder.decode(raw)
        except msgspec.ValidationError as exc:
            return None, f"schema: {exc}"
        except msgspec.DecodeError as exc:
            return None, f"json: {exc}"
        if isinstance(item, Press) and item.action not in self.actions:
            return None, f"action: {item.action!r} is not one of {sorted(self.actions)}"
        if isinstance(item, Cruise) and not self.cruise:
            return None, "cruise: this node has no cruise control"
        return item, ""

    def _is_answer(self, raw: str) -> bool:
        """Whether a long frame says it is an answer (the one input allowed to be long);
        only its `type` is read, and only when the frame is longer than the others may be."""
        if len(raw) <= MAX_INPUT_BYTES or len(raw) > MAX_ANSWER_BYTES:
            return False
        try:
            return self._envelope.decode(raw).type == "answer"
        except msgspec.DecodeError:
            return False


class _Envelope(msgspec.Struct, frozen=True):
    type: str = ""
