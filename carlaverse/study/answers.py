"""Questionnaire answers on disk: one JSON line per event, appended and fsynced before
anything else happens, so a crash of the runner, the node or the machine loses nothing that
was stored (issue 44).

A study's answers file (e.g. `<study out>/answers.jsonl`) holds two kinds of line:

    {"type":"asked","unix_s":…,"node_id":"p01-drive","request":{QuestionnaireRequest as map}}
    {"type":"answers","unix_s":…,"node_id":"p01-drive","trial":"t1","questionnaire":"ssq",
     "request_id":"t1.ssq","seq":3,"final":false,"answers":{"fatigue":1,…},"scores":{}}

An `answers` line is written for every set a node sends: partial sets (`final: false`) as
the participant clicks, then the complete one (`final: true`) with its `scores`. The newest
line of a request is its best set (`latest_answers`). A line cut short by a crash while it
was written is skipped when read, and counted.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import msgspec

from carlaverse import messages as m

ANSWERS_NAME = "answers.jsonl"  # a study run's answers file, in its output folder


class Asked(msgspec.Struct, frozen=True, tag="asked"):
    """A questionnaire was sent to a node (its items, for the export)."""

    unix_s: float  # [s] wall clock of the runner's host
    node_id: str
    request: m.QuestionnaireRequest


class AnswerRecord(msgspec.Struct, frozen=True, tag="answers"):
    """One answer set from a node, as received (partial or final), with scores when final."""

    unix_s: float  # [s] wall clock of the runner's host when it arrived
    node_id: str
    trial: str
    questionnaire: str
    request_id: str
    seq: int
    final: bool
    answers: dict[str, int | str]
    scores: dict[str, float] = {}  # final sets of a scored questionnaire


Line = Asked | AnswerRecord
_DECODER = msgspec.json.Decoder(Line)
_ENCODER = msgspec.json.Encoder()


class AnswerStore:
    """Appends records to one JSON-lines file, each written whole and fsynced."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        new = not self.path.exists()
        # O_APPEND: each record goes to the end in one write, even with two writers.
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
        if new:
            _fsync_dir(self.path.parent)  # the file's name survives a power cut too
        self.written = 0

    def asked(self, node_id: str, request: m.QuestionnaireRequest) -> Asked:
        record = Asked(time.time(), node_id, request)
        self._append(record)
        return record

    def answered(
        self, request: m.QuestionnaireRequest, answers: m.QuestionnaireAnswers,
        scores: dict[str, float] | None = None,
    ) -> AnswerRecord:  # fmt: skip
        record = AnswerRecord(
            time.time(), answers.node_id, request.trial, request.questionnaire,
            request.request_id, answers.seq, answers.final, dict(answers.answers), scores or {},
        )  # fmt: skip
        self._append(record)
        return record

    def _append(self, record: Line) -> None:
        line = _ENCODER.encode(record) + b"\n"
        written = os.write(self._fd, line)
        if written != len(line):  # a full disk: say so rather than keep half a line
            raise OSError(f"{self.path}: wrote {written} of {len(line)} bytes of an answer")
        os.fsync(self._fd)
        self.written += 1

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> AnswerStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_answers(path: str | Path) -> tuple[list[Line], int]:
    """Every whole record of an answers file, in order, and how many lines were skipped
    (cut short by a crash, or not records of this format)."""
    records: list[Line] = []
    skipped = 0
    with open(path, "rb") as f:
        for raw in f:
            if not raw.strip():
                continue
            try:
                records.append(_DECODER.decode(raw))
            except msgspec.DecodeError:  # ValidationError included
                skipped += 1
    return records, skipped


def latest_answers(records: list[Line]) -> dict[tuple[str, str], AnswerRecord]:
    """(node id, request id) -> the best set stored: the final one, else the newest partial."""
    best: dict[tuple[str, str], AnswerRecord] = {}
    for record in records:
        if not isinstance(record, AnswerRecord):
            continue
        key = (record.node_id, record.request_id)
        held = best.get(key)
        if held is None or not held.final:  # a final set stands; a repeat of it adds nothing
            best[key] = record
    return best


def answer_rows(records: list[Line]) -> list[dict[str, Any]]:
    """One flat row per (node, request), its best set (`latest_answers`), for a table export:
    node_id, trial, questionnaire, request_id, final, unix_s, then `item.<id>` per answer
    and `score.<name>` per score, in the order the records came."""
    return [_row(record) for record in latest_answers(records).values()]


def _row(r: AnswerRecord) -> dict[str, Any]:
    head = {"node_id": r.node_id, "trial": r.trial, "questionnaire": r.questionnaire,
            "request_id": r.request_id, "final": r.final, "unix_s": r.unix_s}  # fmt: skip
    items = {f"item.{key}": value for key, value in r.answers.items()}
    return head | items | {f"score.{name}": value for name, value in r.scores.items()}


def to_builtins(record: Line) -> dict[str, Any]:
    """A record as plain JSON-able data (for an export)."""
    return msgspec.to_builtins(record)


def _fsync_dir(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
