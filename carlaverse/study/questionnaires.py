"""Questionnaires between trials: what a participant's page shows, and how answers are scored.

Three kinds, each a `Questionnaire` whose items are the wire's `QuestionnaireItem`s:

    ssq()                 Simulator Sickness Questionnaire (Kennedy et al. 1993): 16 symptoms
                          rated 0-3 (none, slight, moderate, severe), scored into Nausea,
                          Oculomotor, Disorientation and Total with the published weights
    nasa_tlx()            NASA Task Load Index (Hart & Staveland 1988): 6 subscales rated 0-100
                          in steps of 5 (21 points); raw TLX is their mean; with the 15
                          pairwise comparisons (`weighted=True`) each subscale is weighted by
                          how often it was chosen (0-5, the weights sum to 15)
    load_questionnaire()  a study's own items from YAML: Likert scales, single choices, text

`score(questionnaire, answers)` gives a complete answer set's scores (a dict of floats, named
as the export writes them); `check_answers` vets answers that came over the network against
the items that were asked.

    ssq_scores = score(ssq(), {"general_discomfort": 1, ...})   # {"nausea": 9.54, ...}
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import Annotated

import msgspec

from carlaverse import messages as m
from carlaverse.config import (
    ConfigError,
    StrictStruct,
    convert,
    parse_yaml,
    read_text,
    resolve_path,
)

Answers = Mapping[str, int | str]  # item id -> scale value, choice index or text
Scorer = Callable[[Answers], dict[str, float]]

# --------------------------------------------------------------------------- SSQ

# Kennedy, Lane, Berbaum & Lilienthal (1993), "Simulator Sickness Questionnaire: an enhanced
# method for quantifying simulator sickness", Int. J. Aviation Psychology 3(3), Table 1:
# each symptom's subscales (N nausea, O oculomotor, D disorientation); five load on two.
SSQ_SYMPTOMS: tuple[tuple[str, str, str], ...] = (
    ("general_discomfort", "General discomfort", "NO"),
    ("fatigue", "Fatigue", "O"),
    ("headache", "Headache", "O"),
    ("eyestrain", "Eyestrain", "O"),
    ("difficulty_focusing", "Difficulty focusing", "OD"),
    ("increased_salivation", "Increased salivation", "N"),
    ("sweating", "Sweating", "N"),
    ("nausea", "Nausea", "ND"),
    ("difficulty_concentrating", "Difficulty concentrating", "NO"),
    ("fullness_of_head", "Fullness of head", "D"),
    ("blurred_vision", "Blurred vision", "OD"),
    ("dizzy_eyes_open", "Dizziness (eyes open)", "D"),
    ("dizzy_eyes_closed", "Dizziness (eyes closed)", "D"),
    ("vertigo", "Vertigo", "D"),
    ("stomach_awareness", "Stomach awareness", "N"),
    ("burping", "Burping", "N"),
)
SSQ_SEVERITY = ("None", "Slight", "Moderate", "Severe")  # rated 0, 1, 2, 3
# The published weights: each subscale's raw sum times its weight; the total is the sum of
# the three raw sums (a two-subscale symptom counted twice) times 3.74.
SSQ_WEIGHTS = {"N": 9.54, "O": 7.58, "D": 13.92}
SSQ_TOTAL_WEIGHT = 3.74
_SSQ_NAMES = {"N": "nausea", "O": "oculomotor", "D": "disorientation"}


def ssq() -> Questionnaire:
    """The Simulator Sickness Questionnaire: 16 symptoms, each rated 0-3."""
    items = tuple(
        m.QuestionnaireItem(key, text, "scale", 0, 3, labels=list(SSQ_SEVERITY))
        for key, text, _ in SSQ_SYMPTOMS
    )
    return Questionnaire(
        "ssq", "Simulator Sickness Questionnaire", items, _score_ssq,
        "How much is each symptom affecting you right now?",
    )  # fmt: skip


def _score_ssq(answers: Answers) -> dict[str, float]:
    raw = dict.fromkeys(SSQ_WEIGHTS, 0)
    for key, _, scales in SSQ_SYMPTOMS:
        for scale in scales:
            raw[scale] += _rating(answers, key)
    scores = {_SSQ_NAMES[s]: round(raw[s] * w, 2) for s, w in SSQ_WEIGHTS.items()}
    scores["total"] = round(sum(raw.values()) * SSQ_TOTAL_WEIGHT, 2)
    return scores


# --------------------------------------------------------------------------- NASA-TLX

TLX_SUBSCALES: tuple[tuple[str, str, str, str], ...] = (
    # id, name, question (NASA TLX paper-and-pencil form), anchors at 0 and 100
    ("mental", "Mental Demand", "How mentally demanding was the task?", "Very Low|Very High"),
    ("physical", "Physical Demand", "How physically demanding was the task?",
     "Very Low|Very High"),
    ("temporal", "Temporal Demand", "How hurried or rushed was the pace of the task?",
     "Very Low|Very High"),
    ("performance", "Performance", "How successful were you in accomplishing what you were "
     "asked to do?", "Perfect|Failure"),
    ("effort", "Effort", "How hard did you have to work to accomplish your level of "
     "performance?", "Very Low|Very High"),
    ("frustration", "Frustration", "How insecure, discouraged, irritated, stressed, and "
     "annoyed were you?", "Very Low|Very High"),
)  # fmt: skip
TLX_IDS = tuple(s[0] for s in TLX_SUBSCALES)
TLX_PAIRS = tuple(combinations(TLX_IDS, 2))  # the 15 pairwise comparisons
TLX_PAIR_PREFIX = "pair."


def nasa_tlx(weighted: bool = True, seed: int | None = None) -> Questionnaire:
    """NASA-TLX: six ratings 0-100 in steps of 5; with `weighted`, the 15 pairwise choices.
    With `seed` (e.g. per participant and trial) the pairs come in a shuffled order, each
    with its two sides in a shuffled order, as the TLX procedure presents them; the same
    seed gives the same order."""
    names = {key: name for key, name, _, _ in TLX_SUBSCALES}
    items = [
        m.QuestionnaireItem(key, f"{name}: {question}", "scale", 0, 100, 5, anchors.split("|"))
        for key, name, question, anchors in TLX_SUBSCALES
    ]
    if weighted:
        items += [
            m.QuestionnaireItem(pair_item_id(a, b), "Which contributed more to the workload?",
                                "choice", labels=[names[a], names[b]])
            for a, b in _pair_order(seed)
        ]  # fmt: skip
    return Questionnaire(
        "nasa-tlx" if weighted else "raw-tlx", "NASA Task Load Index", tuple(items), _score_tlx,
        "Rate each aspect of the task you just did.",
    )  # fmt: skip


def _pair_order(seed: int | None) -> list[tuple[str, str]]:
    pairs = list(TLX_PAIRS)
    if seed is None:
        return pairs
    rng = random.Random(seed)
    rng.shuffle(pairs)
    return [(b, a) if rng.random() < 0.5 else (a, b) for a, b in pairs]


def pair_item_id(a: str, b: str) -> str:
    """The item of the pair shown as `a` (answer 0) or `b` (answer 1)."""
    return f"{TLX_PAIR_PREFIX}{a}.{b}"


def tlx_weights(chosen: Mapping[tuple[str, str], str]) -> dict[str, int]:
    """Each subscale's weight: how often it was chosen in the 15 comparisons (0-5, sum 15).
    `chosen` maps each unordered pair, once, to the subscale picked from it."""
    seen = {frozenset(pair) for pair in chosen}
    wanted = {frozenset(pair) for pair in TLX_PAIRS}
    if len(seen) != len(chosen) or seen != wanted:
        missing = sorted("/".join(sorted(p)) for p in wanted - seen)
        extra = sorted("/".join(sorted(p)) for p in seen - wanted)
        raise ValueError(f"NASA-TLX needs each of the 15 pairs once: missing {missing}, "
                         f"not pairs {extra}, {len(chosen) - len(seen)} repeated")  # fmt: skip
    for pair, winner in chosen.items():
        if winner not in pair:
            raise ValueError(f"NASA-TLX pair {pair}: {winner!r} is not one of the two")
    tally = Counter(chosen.values())
    return {key: tally[key] for key in TLX_IDS}


def _score_tlx(answers: Answers) -> dict[str, float]:
    ratings = {key: _rating(answers, key) for key in TLX_IDS}
    scores = {key: float(value) for key, value in ratings.items()}
    scores["raw_tlx"] = round(sum(ratings.values()) / len(ratings), 4)
    pairs = _picks(answers)
    if pairs:  # the raw-only form asks none
        weights = tlx_weights(pairs)
        scores |= {f"weight_{key}": float(w) for key, w in weights.items()}
        weighted = sum(weights[k] * ratings[k] for k in TLX_IDS) / len(TLX_PAIRS)
        scores["weighted_tlx"] = round(weighted, 4)
    return scores


def _picks(answers: Answers) -> dict[tuple[str, str], str]:
    """(shown first, shown second) -> the subscale picked, read from the pair items' ids."""
    picks = {}
    for key, index in answers.items():
        if key.startswith(TLX_PAIR_PREFIX):
            a, _, b = key.removeprefix(TLX_PAIR_PREFIX).partition(".")
            if index not in (0, 1) or isinstance(index, bool):
                raise ValueError(f"NASA-TLX pair {a}/{b}: answer {index!r} is not 0 or 1")
            picks[(a, b)] = (a, b)[int(index)]
    return picks


def _rating(answers: Answers, key: str) -> int:
    value = answers.get(key)
    if not isinstance(value, int) or isinstance(value, bool):
        raise ValueError(f"item {key!r}: no rating in the answers (got {value!r})")
    return value


# --------------------------------------------------------------------------- the questionnaire


@dataclass(frozen=True, slots=True)
class Questionnaire:
    """A questionnaire's items as shown, and its scoring (None: answers are kept as given)."""

    id: str
    title: str
    items: tuple[m.QuestionnaireItem, ...]
    scorer: Scorer | None = field(default=None, compare=False)
    instructions: str = ""

    def request(self, trial: str, request_id: str | None = None) -> m.QuestionnaireRequest:
        """The message that asks a node to show this for `trial`."""
        return m.QuestionnaireRequest(
            m.SCHEMA_VERSION, request_id or f"{trial}.{self.id}", trial, self.id, self.title,
            list(self.items), self.instructions,
        )  # fmt: skip


def score(questionnaire: Questionnaire, answers: Answers) -> dict[str, float]:
    """The scores of a complete answer set ({} for a questionnaire without scoring).
    Raises ValueError naming the item when an answer it needs is missing or off."""
    problems = check_answers(questionnaire.items, answers)
    if problems:
        raise ValueError(f"{questionnaire.id}: {problems[0]}")
    return questionnaire.scorer(answers) if questionnaire.scorer is not None else {}


# name -> the questionnaire, given a seed for what it shuffles (only the TLX pairs do)
BUILT_IN: dict[str, Callable[[int | None], Questionnaire]] = {
    "ssq": lambda seed: ssq(),
    "nasa-tlx": lambda seed: nasa_tlx(weighted=True, seed=seed),
    "raw-tlx": lambda seed: nasa_tlx(weighted=False),
}


def find_questionnaire(
    name: str, relative_to: Path | None = None, seed: int | None = None
) -> Questionnaire:
    """A built-in questionnaire by name (`ssq`, `nasa-tlx`, `raw-tlx`), or one of a study's
    own from its YAML file (a path, relative to `relative_to`, e.g. the study file's folder).
    `seed`: for a form that shuffles (the NASA-TLX pairs), e.g. one per participant and trial.
    ConfigError naming `name` and the choices otherwise."""
    if name in BUILT_IN:
        return BUILT_IN[name](seed)
    if not name.endswith((".yaml", ".yml")):
        raise ConfigError(name, f"no such questionnaire: built in are {sorted(BUILT_IN)}, "
                          "or name a YAML file of your own (e.g. comfort.yaml)")  # fmt: skip
    return load_questionnaire(resolve_path(name, relative_to))


# --------------------------------------------------------------------------- answers from outside


def check_answers(
    items: tuple[m.QuestionnaireItem, ...] | list[m.QuestionnaireItem],
    answers: Answers,
    final: bool = True,
) -> list[str]:
    """What is wrong with `answers` to `items`, one line each; [] when nothing is. A partial
    set (`final=False`) may leave required items out."""
    by_id = {item.id: item for item in items}
    problems = [f"unknown item {key!r}" for key in answers if key not in by_id]
    for key, value in answers.items():
        if key in by_id:
            problems += _value_problem(by_id[key], value)
    if final:
        problems += [f"item {i.id!r}: required, not answered" for i in items
                     if i.required and i.id not in answers]  # fmt: skip
    return problems


def _value_problem(item: m.QuestionnaireItem, value: int | str) -> list[str]:
    if item.kind == "text":
        if not isinstance(value, str):
            return [f"item {item.id!r}: text expected, got {value!r}"]
        if len(value) > item.max_chars:
            return [f"item {item.id!r}: {len(value)} characters > max_chars {item.max_chars}"]
        return []
    if not isinstance(value, int) or isinstance(value, bool):
        return [f"item {item.id!r}: a number expected, got {value!r}"]
    if item.kind == "choice":
        ok = 0 <= value < len(item.labels)
        return [] if ok else [f"item {item.id!r}: option {value} of {len(item.labels)}"]
    on_scale = item.low <= value <= item.high and (value - item.low) % item.step == 0
    where = f"{item.low}..{item.high} step {item.step}"
    return [] if on_scale else [f"item {item.id!r}: {value} is off the scale {where}"]


# --------------------------------------------------------------------------- YAML

Label = Annotated[str, msgspec.Meta(min_length=1, max_length=500)]
Points = Annotated[int, msgspec.Meta(ge=2, le=11)]
MaxChars = Annotated[int, msgspec.Meta(ge=1, le=m.QUESTIONNAIRE_MAX_TEXT)]


class ItemSpec(StrictStruct):
    """One item: exactly one of `likert`, `choice`, `free_text` says its kind."""

    id: m.StudyId
    text: Label
    likert: Points | None = None  # a scale of this many points, answered 1..N
    anchors: list[Label] = []  # likert: the two ends' labels, or one per point
    choice: Annotated[list[Label], msgspec.Meta(min_length=2, max_length=32)] | None = None
    free_text: MaxChars | None = None  # free text of at most this many characters
    required: bool = True


class QuestionnaireSpec(StrictStruct):
    """A study's own questionnaire, as its YAML file says it:

    id: comfort
    title: Ride comfort
    instructions: About the drive you just finished.
    items:
      - {id: comfort, text: How comfortable was the ride?, likert: 7,
         anchors: [Very uncomfortable, Very comfortable]}
      - {id: lane, text: Which lane felt safer?, choice: [Left, Right]}
      - {id: remarks, text: Anything else?, free_text: 300, required: false}
    """

    id: m.StudyId
    title: Label
    items: Annotated[
        list[ItemSpec], msgspec.Meta(min_length=1, max_length=m.QUESTIONNAIRE_MAX_ITEMS)
    ]
    instructions: Annotated[str, msgspec.Meta(max_length=m.QUESTIONNAIRE_MAX_TEXT)] = ""


def load_questionnaire(path: str | Path) -> Questionnaire:
    """A questionnaire from a YAML file; ConfigError naming the file and the field."""
    resolved = resolve_path(path)
    spec = convert(parse_yaml(read_text(resolved), str(resolved)), QuestionnaireSpec, str(resolved))
    return from_spec(spec, str(resolved))


def from_spec(spec: QuestionnaireSpec, source: str = "questionnaire") -> Questionnaire:
    """The questionnaire a spec describes; ConfigError naming the item that cannot be one."""
    items = []
    for index, s in enumerate(spec.items):
        try:
            items.append(_item(s))
        except ValueError as exc:
            raise ConfigError(source, f"{exc} - at `$.items[{index}]`") from None
    ids = [i.id for i in items]
    repeated = sorted({i for i in ids if ids.count(i) > 1})
    if repeated:
        raise ConfigError(source, f"item ids repeated: {repeated} - at `$.items`")
    return Questionnaire(spec.id, spec.title, tuple(items), None, spec.instructions)


def _item(s: ItemSpec) -> m.QuestionnaireItem:
    shapes = [k for k in ("likert", "choice", "free_text") if getattr(s, k) is not None]
    if len(shapes) != 1:
        raise ValueError(
            f"item {s.id!r} needs exactly one of `likert`, `choice`, `free_text` "
            f"(has {shapes or 'none'})"
        )
    if s.anchors and s.likert is None:
        raise ValueError(f"item {s.id!r}: `anchors` belong to a `likert` item")
    if s.likert is not None:
        return m.QuestionnaireItem(s.id, s.text, "scale", 1, s.likert, 1, s.anchors, s.required)
    if s.choice is not None:
        return m.QuestionnaireItem(s.id, s.text, "choice", labels=s.choice, required=s.required)
    assert s.free_text is not None
    return m.QuestionnaireItem(s.id, s.text, "text", required=s.required, max_chars=s.free_text)
