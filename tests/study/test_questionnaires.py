"""Questionnaire scoring against the published tables and formulas, worked by hand here."""

from __future__ import annotations

from pathlib import Path

import msgpack
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.config import ConfigError
from carlaverse.hmi.questionnaire import QuestionnaireDesk
from carlaverse.study import questionnaires as q

# Kennedy, Lane, Berbaum & Lilienthal (1993), Int. J. Aviation Psychology 3(3):203-220, Table 1
# ("SSQ score calculations"), copied here from the paper, not from the code: a 1 marks the
# subscales each symptom is weighted into (N nausea, O oculomotor, D disorientation).
#                             N  O  D
PAPER_TABLE = {
    "general_discomfort":       (1, 1, 0),
    "fatigue":                  (0, 1, 0),
    "headache":                 (0, 1, 0),
    "eyestrain":                (0, 1, 0),
    "difficulty_focusing":      (0, 1, 1),
    "increased_salivation":     (1, 0, 0),
    "sweating":                 (1, 0, 0),
    "nausea":                   (1, 0, 1),
    "difficulty_concentrating": (1, 1, 0),
    "fullness_of_head":         (0, 0, 1),
    "blurred_vision":           (0, 1, 1),
    "dizzy_eyes_open":          (0, 0, 1),
    "dizzy_eyes_closed":        (0, 0, 1),
    "vertigo":                  (0, 0, 1),
    "stomach_awareness":        (1, 0, 0),
    "burping":                  (1, 0, 0),
}  # fmt: skip
# Each column has 7 ones, so the largest raw sum of a column is 7 x 3 = 21, and the paper's
# maxima are 21 x 9.54 = 200.34, 21 x 7.58 = 159.18, 21 x 13.92 = 292.32 and, for the total,
# (21 + 21 + 21) x 3.74 = 235.62.


def ssq_answers(**ratings: int) -> dict[str, int]:
    return {symptom: ratings.get(symptom, 0) for symptom in PAPER_TABLE}


def test_the_ssq_asks_the_papers_sixteen_symptoms_with_the_papers_subscales() -> None:
    columns = [sum(row[i] for row in PAPER_TABLE.values()) for i in range(3)]
    assert columns == [7, 7, 7]
    coded = {key: tuple(int(s in scales) for s in "NOD") for key, _, scales in q.SSQ_SYMPTOMS}
    assert coded == PAPER_TABLE
    assert [i.id for i in q.ssq().items] == list(PAPER_TABLE)
    assert all((i.low, i.high, i.step) == (0, 3, 1) for i in q.ssq().items)


@pytest.mark.parametrize(
    ("answers", "expected"),
    [
        # none of the symptoms: every score 0
        (ssq_answers(), {"nausea": 0, "oculomotor": 0, "disorientation": 0, "total": 0}),
        # every symptom severe (3): the paper's maxima (see above)
        ({k: 3 for k in PAPER_TABLE},
         {"nausea": 200.34, "oculomotor": 159.18, "disorientation": 292.32, "total": 235.62}),
        # nausea 2 (N, D), headache 1 (O), vertigo 3 (D): raw N 2, O 1, D 2 + 3 = 5;
        # N 2 x 9.54 = 19.08, O 1 x 7.58 = 7.58, D 5 x 13.92 = 69.6, total 8 x 3.74 = 29.92
        (ssq_answers(nausea=2, headache=1, vertigo=3),
         {"nausea": 19.08, "oculomotor": 7.58, "disorientation": 69.6, "total": 29.92}),
        # general discomfort 1 (N, O), difficulty focusing 2 (O, D), blurred vision 1 (O, D):
        # raw N 1, O 1 + 2 + 1 = 4, D 2 + 1 = 3; N 9.54, O 4 x 7.58 = 30.32,
        # D 3 x 13.92 = 41.76, total (1 + 4 + 3) x 3.74 = 29.92
        (ssq_answers(general_discomfort=1, difficulty_focusing=2, blurred_vision=1),
         {"nausea": 9.54, "oculomotor": 30.32, "disorientation": 41.76, "total": 29.92}),
    ],
)  # fmt: skip
def test_ssq_scores_are_the_papers_weights_applied_by_hand(answers, expected) -> None:
    assert q.score(q.ssq(), answers) == pytest.approx(expected, abs=1e-9)


# NASA-TLX (Hart & Staveland 1988; NASA TLX manual 1986): raw TLX = mean of the six ratings;
# weighted = sum(weight x rating) / 15, a weight being how often its subscale was picked in the
# 15 pairwise comparisons. Ratings and picks of one participant, worked by hand:
TLX_RATINGS = {"mental": 70, "physical": 20, "temporal": 55, "performance": 30, "effort": 65,
               "frustration": 40}  # fmt: skip
# In every pair the participant picks the one earlier in this order, so the weights are
# mental 5, effort 4, temporal 3, frustration 2, performance 1, physical 0 (sum 15).
PREFERENCE = ["mental", "effort", "temporal", "frustration", "performance", "physical"]
# raw = (70 + 20 + 55 + 30 + 65 + 40) / 6 = 280 / 6 = 46.666…
# weighted = (5x70 + 0x20 + 3x55 + 1x30 + 4x65 + 2x40) / 15 = (350+165+30+260+80) / 15 = 59
TLX_SUBSCALE_ORDER = ["mental", "physical", "temporal", "performance", "effort", "frustration"]


def tlx_answers() -> dict[str, int]:
    answers: dict[str, int] = dict(TLX_RATINGS)
    for i, a in enumerate(TLX_SUBSCALE_ORDER):
        for b in TLX_SUBSCALE_ORDER[i + 1 :]:
            answers[f"pair.{a}.{b}"] = 0 if PREFERENCE.index(a) < PREFERENCE.index(b) else 1
    return answers


def test_nasa_tlx_raw_and_weighted_scores_worked_by_hand() -> None:
    scores = q.score(q.nasa_tlx(), tlx_answers())
    assert scores["raw_tlx"] == pytest.approx(280 / 6, abs=1e-4)
    assert scores["weighted_tlx"] == pytest.approx(59.0)
    weights = {k: scores[f"weight_{k}"] for k in TLX_RATINGS}
    assert weights == {"mental": 5, "effort": 4, "temporal": 3, "frustration": 2,
                       "performance": 1, "physical": 0}  # fmt: skip


def test_nasa_tlx_asks_21_point_scales_and_the_15_pairs() -> None:
    items = q.nasa_tlx().items
    scales = [i for i in items if i.kind == "scale"]
    assert [i.id for i in scales] == TLX_SUBSCALE_ORDER
    assert all(i.points() == 21 and (i.low, i.high, i.step) == (0, 100, 5) for i in scales)
    assert len([i for i in items if i.kind == "choice"]) == 15  # 6 choose 2
    raw = q.nasa_tlx(weighted=False)
    assert q.score(raw, TLX_RATINGS) == {**{k: float(v) for k, v in TLX_RATINGS.items()},
                                         "raw_tlx": pytest.approx(280 / 6, abs=1e-4)}  # fmt: skip


def test_the_pairwise_set_must_be_the_15_pairs_each_once() -> None:
    picks = {(a, b): a for a, b in q.TLX_PAIRS}
    assert sum(q.tlx_weights(picks).values()) == 15
    short = dict(list(picks.items())[:-1])
    with pytest.raises(ValueError, match=r"missing.*effort/frustration"):
        q.tlx_weights(short)
    with pytest.raises(ValueError, match="1 repeated"):
        q.tlx_weights({**short, ("physical", "mental"): "mental"})
    with pytest.raises(ValueError, match="'effort' is not one of the two"):
        q.tlx_weights({**picks, ("mental", "physical"): "effort"})


def test_scoring_refuses_an_incomplete_or_off_scale_set_naming_the_item() -> None:
    answers = tlx_answers()
    del answers["pair.mental.physical"]
    with pytest.raises(ValueError, match=r"'pair.mental.physical': required"):
        q.score(q.nasa_tlx(), answers)
    with pytest.raises(ValueError, match=r"'fatigue': 4 is off the scale 0..3"):
        q.score(q.ssq(), {**ssq_answers(), "fatigue": 4})


def test_answers_from_outside_are_checked_item_by_item() -> None:
    items = [*q.nasa_tlx().items, m.QuestionnaireItem("note", "Notes", "text", max_chars=10)]
    problems = q.check_answers(items, {
        "mental": 52, "physical": True, "pair.mental.physical": 2, "bogus": 1,
        "note": "x" * 11, "effort": "high",
    }, final=False)  # fmt: skip
    assert sorted(problems) == sorted([
        "unknown item 'bogus'",
        "item 'mental': 52 is off the scale 0..100 step 5",
        "item 'physical': a number expected, got True",
        "item 'pair.mental.physical': option 2 of 2",
        "item 'note': 11 characters > max_chars 10",
        "item 'effort': a number expected, got 'high'",
    ])  # fmt: skip
    assert q.check_answers(items, {"mental": 55}, final=False) == []  # partial: fine


def test_a_request_travels_and_a_bad_item_is_refused_naming_its_path() -> None:
    request = q.ssq().request("trial-2")
    assert request.request_id == "trial-2.ssq"
    assert m.QUESTIONNAIRE_REQUEST.decode(m.QUESTIONNAIRE_REQUEST.encode(request)) == request
    raw = msgpack.unpackb(m.QUESTIONNAIRE_REQUEST.encode(request))
    raw["items"][3]["high"] = -1
    with pytest.raises(m.MessageError, match=r"high > low.*\$\.items\[3\]"):
        m.QUESTIONNAIRE_REQUEST.decode(msgpack.packb(raw))
    raw["items"][3]["high"], raw["items"][3]["id"] = 3, "a/b"
    with pytest.raises(m.MessageError, match=r"\$\.items\[3\]\.id"):
        m.QUESTIONNAIRE_REQUEST.decode(msgpack.packb(raw))


CUSTOM = """\
id: comfort
title: Ride comfort
instructions: About the drive you just finished.
items:
  - id: comfort
    text: How comfortable was the ride?
    likert: 7
    anchors: [Very uncomfortable, Very comfortable]
  - id: lane
    text: Which lane felt safer?
    choice: [Left, Right, Neither]
  - id: remarks
    text: Anything else?
    free_text: 300
    required: false
"""


def test_a_custom_questionnaire_loads_from_yaml(tmp_path: Path) -> None:
    path = tmp_path / "comfort.yaml"
    path.write_text(CUSTOM)
    loaded = q.load_questionnaire(path)
    likert, choice, text = loaded.items
    assert (likert.kind, likert.low, likert.high, likert.labels[0]) == (
        "scale", 1, 7, "Very uncomfortable")  # fmt: skip
    assert (choice.kind, choice.labels) == ("choice", ["Left", "Right", "Neither"])
    assert (text.kind, text.max_chars, text.required) == ("text", 300, False)
    assert q.score(loaded, {"comfort": 6, "lane": 2}) == {}  # kept as given, not scored
    with pytest.raises(ValueError, match=r"'comfort': 8 is off the scale 1..7"):
        q.score(loaded, {"comfort": 8, "lane": 2})


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("likert: 7", "liker: 7"), r"unknown field `liker` - at `\$.items\[0\]`"),
        (("likert: 7", "likert: 12"), r"<= 11 - at `\$.items\[0\].likert`"),
        (("choice: [Left, Right, Neither]", "choice: [Left]"),
         r"length >= 2 - at `\$.items\[1\].choice`"),
        (("free_text: 300", "free_text: 300\n    likert: 5"),
         r"'remarks' needs exactly one of .*\['likert', 'free_text'\].* at `\$.items\[2\]`"),
        (("Very uncomfortable, ", ""), r"labels: none, the two ends.* at `\$.items\[0\]`"),
        (("id: lane", "id: comfort"), r"item ids repeated: \['comfort'\]"),
        (("title: Ride comfort\n", ""), r"missing required field `title`"),
    ],
)  # fmt: skip
def test_a_bad_custom_questionnaire_is_one_line_naming_the_file_and_field(
    tmp_path: Path, change: tuple[str, str], message: str
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(CUSTOM.replace(*change))
    with pytest.raises(ConfigError, match=message) as caught:
        q.load_questionnaire(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


def test_questionnaires_are_found_by_name_or_by_their_file(tmp_path: Path) -> None:
    assert q.find_questionnaire("ssq").id == "ssq"
    assert len(q.find_questionnaire("raw-tlx").items) == 6
    assert q.find_questionnaire("nasa-tlx", seed=7) == q.nasa_tlx(seed=7) != q.nasa_tlx()
    (tmp_path / "comfort.yaml").write_text(CUSTOM)
    assert q.find_questionnaire("comfort.yaml", tmp_path).id == "comfort"
    with pytest.raises(ConfigError, match=r"sss: no such questionnaire: built in are \['nasa"):
        q.find_questionnaire("sss")


answer_values = st.one_of(
    st.integers(), st.text(max_size=30), st.booleans(), st.none(), st.floats()
)


@given(st.dictionaries(st.text(max_size=20), answer_values, max_size=8), st.booleans())
def test_any_answer_set_from_outside_is_judged_never_raised(answers, final) -> None:
    problems = q.check_answers(q.nasa_tlx().items, answers, final)
    assert isinstance(problems, list)
    if not problems and final:
        q.score(q.nasa_tlx(), answers)  # a set the check lets through scores


@given(st.binary(max_size=300))
def test_any_bytes_on_the_ask_key_are_counted_or_shown_never_raised(payload: bytes) -> None:
    desk = QuestionnaireDesk("p01", lambda _: None)
    desk.receive_request(payload)
    assert desk.requests_shown + sum(desk.requests_dropped.values()) == 1


NAMES = {
    "Mental Demand": "mental", "Physical Demand": "physical", "Temporal Demand": "temporal",
    "Performance": "performance", "Effort": "effort", "Frustration": "frustration",
}  # fmt: skip


def test_seeded_pairs_come_shuffled_and_score_the_same_by_what_was_picked() -> None:
    shown = q.nasa_tlx(seed=7)
    pairs = [i for i in shown.items if i.kind == "choice"]
    sides = [tuple(NAMES[label] for label in i.labels) for i in pairs]
    assert len(sides) == 15 and {frozenset(s) for s in sides} == {frozenset(p) for p in q.TLX_PAIRS}
    assert sides != [tuple(p) for p in q.TLX_PAIRS]  # another order than the definition's
    assert any(s not in q.TLX_PAIRS for s in sides)  # and some pairs shown the other way round
    assert [i.id for i in q.nasa_tlx(seed=7).items] == [i.id for i in shown.items]
    assert [i.id for i in q.nasa_tlx(seed=8).items] != [i.id for i in shown.items]
    # The participant picks, by the label shown, the side earlier in PREFERENCE: the weights
    # and the weighted score are those worked by hand above (59).
    answers: dict[str, int | str] = dict(TLX_RATINGS)
    for item, (a, b) in zip(pairs, sides, strict=True):
        answers[item.id] = 0 if PREFERENCE.index(a) < PREFERENCE.index(b) else 1
    assert q.score(shown, answers)["weighted_tlx"] == pytest.approx(59.0)
