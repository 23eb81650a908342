"""The study's messages (issue 44): questionnaires shown on a participant's HMI and their
answers, and the brief a study's runner gives each participant's agent.

Questionnaires. Between trials the study runner asks a participant's node to show a
questionnaire on the participant's own screen, the node's web HMI (`study/<id>/ask`). The node
answers on `study/<id>/answers` with every answer given so far, each time one changes, and once
more with `final` set when the participant submits. Each answers message holds the whole set so
far, so the newest is the partial set when a node goes away mid-way. The runner repeats its
request until the final set comes; a node that sent it already sends it again, so no single
lost message loses answers. Answers are checked against the request they answer
(carlaverse.study.questionnaires): an unknown item, a value off the scale or too long a text is
counted and dropped by the runner.

Trials. A study's runner briefs each participant's agent (`carlaverse study agent`, on the
participant's machine) on `carlaverse/<study>/study/<participant>/brief`, the study's name
standing as the session: the trial to take part in now, or none. The brief is put again every
half second, so an agent that starts or reconnects late hears it; the agent starts the
participant's node in the trial's session with the brief's node config, and stops it when a
brief names another trial or none.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec

from carlaverse.messages.base import Int64, Seq
from carlaverse.messages.codec import Codec
from carlaverse.patterns import anchored

# --------------------------------------------------------------------------- questionnaires

QUESTIONNAIRE_MAX_ITEMS = 64
QUESTIONNAIRE_MAX_POINTS = 101  # values of a scale, options of a choice
QUESTIONNAIRE_MAX_TEXT = 2000  # [characters] of a free-text answer or of instructions
StudyId = Annotated[str, msgspec.Meta(pattern=anchored(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,62}"))]
ShortText = Annotated[str, msgspec.Meta(max_length=500)]
LongText = Annotated[str, msgspec.Meta(max_length=QUESTIONNAIRE_MAX_TEXT)]
ScaleValue = Annotated[int, msgspec.Meta(ge=-1000, le=1000)]


class QuestionnaireItem(msgspec.Struct, frozen=True):
    """One question as a participant's page shows it."""

    id: StudyId
    text: ShortText
    kind: Literal["scale", "choice", "text"]
    low: ScaleValue = 0  # scale: the lowest value
    high: ScaleValue = 0  # scale: the highest value
    step: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 1  # scale: between neighbouring values
    # scale: the two ends' anchors, or one per value; choice: the options (answer: the index)
    labels: Annotated[list[ShortText], msgspec.Meta(max_length=QUESTIONNAIRE_MAX_POINTS)] = []
    required: bool = True  # the page submits only when it is answered
    max_chars: Annotated[int, msgspec.Meta(ge=1, le=QUESTIONNAIRE_MAX_TEXT)] = 500  # text

    def __post_init__(self) -> None:  # msgspec turns this ValueError into its decode error
        problem = _item_problem(self)
        if problem:
            raise ValueError(f"item {self.id!r}: {problem}")

    def points(self) -> int:
        """How many values a scale has, or options a choice; 0 for text."""
        if self.kind == "scale":
            return (self.high - self.low) // self.step + 1
        return len(self.labels) if self.kind == "choice" else 0


def _item_problem(item: QuestionnaireItem) -> str:
    """What makes an item unshowable, or ""."""
    points = item.points()
    if item.kind == "scale" and not (
        item.high > item.low and (item.high - item.low) % item.step == 0
    ):
        return "a scale needs high > low, in whole steps"
    if item.kind == "scale" and points > QUESTIONNAIRE_MAX_POINTS:
        return f"a scale has at most {QUESTIONNAIRE_MAX_POINTS} values"
    if item.kind == "scale" and len(item.labels) not in (0, 2, points):
        return f"a scale's labels: none, the two ends, or one per value ({points})"
    if item.kind == "choice" and len(item.labels) < 2:
        return "a choice needs two options or more in labels"
    return ""


class QuestionnaireRequest(msgspec.Struct, frozen=True):
    """A questionnaire for a participant's HMI, from the study runner."""

    schema: Int64
    request_id: StudyId  # one per showing (e.g. "<trial>.<questionnaire>"); answers name it
    trial: StudyId
    questionnaire: StudyId  # e.g. "ssq", "nasa-tlx"
    title: ShortText
    items: Annotated[
        list[QuestionnaireItem], msgspec.Meta(min_length=1, max_length=QUESTIONNAIRE_MAX_ITEMS)
    ]
    instructions: LongText = ""


class QuestionnaireAnswers(msgspec.Struct, frozen=True):
    """A participant's answers so far to one QuestionnaireRequest, from the node."""

    schema: Int64
    request_id: StudyId
    node_id: StudyId
    seq: Seq  # counts the sets the node sent for this request
    # item id -> scale value, choice index or text
    answers: Annotated[
        dict[StudyId, ScaleValue | LongText], msgspec.Meta(max_length=QUESTIONNAIRE_MAX_ITEMS)
    ]
    final: bool = False  # the participant submitted: the set is complete


QUESTIONNAIRE_REQUEST: Codec[QuestionnaireRequest] = Codec(QuestionnaireRequest)
QUESTIONNAIRE_ANSWERS: Codec[QuestionnaireAnswers] = Codec(QuestionnaireAnswers)


# --------------------------------------------------------------------------- trials

STUDY_BRIEF_MAX_CONFIG = 65536  # [characters] of a node config in a brief


class TrialBrief(msgspec.Struct, frozen=True):
    """What a study's runner tells one participant's agent, repeated while it holds."""

    schema: Int64
    study: StudyId
    participant: StudyId
    active: bool = False  # False between trials: the agent stops the node
    trial: StudyId = "none"
    attempt: Seq = 0  # a redone trial is a new attempt: a new node in a new session
    session: StudyId = "none"  # the trial's session, where the node joins
    kind: Literal["drive", "bike", "walk", "scripted", "observer"] = "observer"
    condition: StudyId = "none"
    duration_s: Annotated[float, msgspec.Meta(ge=0, le=86400)] = 0.0  # [s] 0: until told
    # the node's config with the condition's overrides merged in (YAML); "" for the kind's own
    node_config_yaml: Annotated[str, msgspec.Meta(max_length=STUDY_BRIEF_MAX_CONFIG)] = ""
    backend: Annotated[str, msgspec.Meta(max_length=32)] = ""  # "sim": devices simulated
    # the participant's link in this trial, as the runner applies it (for the record)
    delay_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0
    jitter_ms: Annotated[float, msgspec.Meta(ge=0, le=5000)] = 0.0
    loss: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.0


TRIAL_BRIEF: Codec[TrialBrief] = Codec(TrialBrief)
