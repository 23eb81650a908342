"""The study export's tables of what was measured beside the drive: questionnaire answers
and scores, and the coverage of each Lab Streaming Layer stream recorded in a trial.

Questionnaires come long, one row per item or score (`measure`), since each questionnaire
has its own: SSQ nausea/oculomotor/disorientation/total, NASA-TLX raw_tlx/weighted_tlx, a
study's own items. The scores are the ones stored with the final answer set, computed by
`questionnaires.score` when the participant finished; a partial set has none.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from carlaverse.study.answers import AnswerRecord, latest_answers, read_answers
from carlaverse.study.export_inputs import Attempt, StudyRun, utc
from carlaverse.study.export_tables import KEYS, TRIAL_KEYS
from carlaverse.study.lsl_sink import TOPIC_PREFIX, lsl_summaries, read_lsl

QUESTIONNAIRES = KEYS | {
    "questionnaire": "ssq, nasa-tlx, raw-tlx or a study's own questionnaire id",
    "request_id": "the request the answers reply to",
    "final": "the participant submitted the set (false: the newest partial set stored)",
    "answered_utc": "when the set arrived at the runner (UTC timestamp)",
    "measure_kind": "score (computed at submission) | item (an answer as given)",
    "measure": "the score's name (total, nausea, raw_tlx, weighted_tlx, ...) or the item id",
    "value": "the score, or the item's scale value / choice index (empty for text)",
    "text": "a text item's answer (empty otherwise)",
}
LSL = TRIAL_KEYS | {
    "stream": "the LSL stream's name (recorded on channel lsl/<name>)",
    "samples": "samples the recorder wrote, as its summary says",
    "samples_in_file": "samples found on the stream's channel in the recording",
    "nominal_srate_hz": "[Hz] the stream's nominal rate (0: irregular)",
    "first_t": "[s] session time of the first sample",
    "last_t": "[s] session time of the last sample",
    "coverage": "samples / ((last_t - first_t) * nominal rate + 1): 1 is none missing",
    "bad_shape": "samples dropped for a wrong channel count",
    "bad_time": "samples dropped for a time that is not finite",
    "error": "why the stream's recording stopped early (empty: it did not)",
    "summarised": "the recording holds the stream's summary (false: cut off by a crash)",
}


def questionnaire_rows(run: StudyRun) -> tuple[list[dict[str, Any]], list[str]]:
    """The rows, and what was left out (one line each: unknown nodes, torn lines)."""
    path = run.answers_file
    if not path.is_file():
        return [], []
    records, skipped = read_answers(path)
    left_out = [f"{path.name}: {skipped} lines that are not whole records"] if skipped else []
    rows: list[dict[str, Any]] = []
    for record in latest_answers(records).values():
        keys = _keys_of(run, record)
        if keys is None:
            # the node's id is not repeated: it is no pseudonym the study knows
            left_out.append(f"{path.name}: answers to {record.request_id!r} from a node that "
                            "is no participant of that trial in the log")  # fmt: skip
            continue
        rows += [keys | _head(record) | r for r in _measures(record)]
    return rows, left_out


def _keys_of(run: StudyRun, record: AnswerRecord) -> dict[str, Any] | None:
    attempt = _attempt_of(run.attempts, record.trial)
    if attempt is None:
        return None
    pid = _participant(record.node_id, attempt)
    seat = next((s for s in run.seats(attempt) if s.participant == pid), None)
    return seat.keys(attempt) if seat is not None else None


def _attempt_of(attempts: list[Attempt], trial: str) -> Attempt | None:
    """The trial's completed attempt, else its latest (answers belong to a trial)."""
    mine = [a for a in attempts if a.trial == trial]
    done = [a for a in mine if a.completed]
    found = done or mine
    return found[-1] if found else None


def _participant(node_id: str, attempt: Attempt) -> str:
    """A participant's node runs under their pseudonym (the agent names it so)."""
    by_lower = {pid.lower(): pid for pid in attempt.conditions}
    return by_lower.get(node_id.lower(), "")


def _head(r: AnswerRecord) -> dict[str, Any]:
    return {"questionnaire": r.questionnaire, "request_id": r.request_id, "final": r.final,
            "answered_utc": utc(r.unix_s)}  # fmt: skip


def _measures(r: AnswerRecord) -> list[dict[str, Any]]:
    scores = [{"measure_kind": "score", "measure": name, "value": float(value), "text": ""}
              for name, value in r.scores.items()]  # fmt: skip
    items = [{"measure_kind": "item", "measure": item,
              "value": None if isinstance(value, str) else float(value),
              "text": value if isinstance(value, str) else ""}
             for item, value in r.answers.items()]  # fmt: skip
    return scores + items


def lsl_rows(attempt: Attempt, recording: Path) -> list[dict[str, Any]]:
    """One row per LSL stream in the attempt's recording."""
    counted = {topic: len(samples) for topic, samples in read_lsl(recording).items()}
    summaries = lsl_summaries(recording)
    keys = attempt.keys() | {"condition": attempt.condition}
    rows = []
    for topic in sorted(set(counted) | set(summaries)):
        s = summaries.get(topic, {})
        rows.append(keys | {
            "stream": topic.removeprefix(TOPIC_PREFIX), "samples": _int(s.get("samples")),
            "samples_in_file": counted.get(topic, 0),
            "nominal_srate_hz": _float(s.get("nominal_srate")),
            "first_t": _float(s.get("first_t")), "last_t": _float(s.get("last_t")),
            "coverage": _float(s.get("coverage")), "bad_shape": _int(s.get("bad_shape")),
            "bad_time": _int(s.get("bad_time")), "error": s.get("error", ""),
            "summarised": bool(s),
        })  # fmt: skip
    return rows


def _int(text: str | None) -> int | None:
    try:
        return int(text) if text is not None else None
    except ValueError:
        return None


def _float(text: str | None) -> float:
    try:
        return float(text) if text is not None else math.nan
    except ValueError:
        return math.nan
