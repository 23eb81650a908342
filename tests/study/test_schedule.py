"""The schedule: balanced Latin squares checked against their defining properties (Williams
1949: every condition once in every position; every ordered pair of conditions adjacent
equally often), counted here by brute force rather than taken from the construction."""

from __future__ import annotations

from collections import Counter
from itertools import permutations

import pytest

from carlaverse.study.schedule import (
    MAIN,
    PRACTICE,
    digest,
    plan,
    shared_conflict,
    shuffled,
    williams_rows,
)
from carlaverse.study.study_file import Condition, Design, Participant, Study


def _pair_counts(rows: list[list[int]]) -> Counter[tuple[int, int]]:
    return Counter((row[i], row[i + 1]) for row in rows for i in range(len(row) - 1))


@pytest.mark.parametrize("n", [2, 4, 6, 8])
def test_williams_even_is_one_balanced_square(n: int) -> None:
    rows = williams_rows(n)
    assert len(rows) == n
    for row in rows:
        assert sorted(row) == list(range(n))  # each condition once per row
    for position in range(n):
        assert sorted(row[position] for row in rows) == list(range(n))  # once per column
    # n(n-1) ordered pairs, n rows of n-1 adjacencies: each pair exactly once
    assert _pair_counts(rows) == Counter(dict.fromkeys(permutations(range(n), 2), 1))


@pytest.mark.parametrize("n", [3, 5, 7])
def test_williams_odd_is_a_square_and_its_mirror(n: int) -> None:
    rows = williams_rows(n)
    assert len(rows) == 2 * n
    for half in (rows[:n], rows[n:]):
        for position in range(n):
            assert sorted(row[position] for row in half) == list(range(n))
    # 2n rows of n-1 adjacencies over n(n-1) ordered pairs: each exactly twice
    assert _pair_counts(rows) == Counter(dict.fromkeys(permutations(range(n), 2), 2))


def test_williams_four_matches_the_published_square() -> None:
    # The 4-condition square as textbooks print it (ABDC / BCAD / CDBA / DACB).
    letters = ["".join("ABCD"[c] for c in row) for row in williams_rows(4)]
    assert letters == ["ABDC", "BCAD", "CDBA", "DACB"]


def test_shuffle_is_reproducible_and_differs_by_participant() -> None:
    assert shuffled(6, 7, "P01", 1) == shuffled(6, 7, "P01", 1)
    assert sorted(shuffled(6, 7, "P01", 1)) == list(range(6))
    orders = {tuple(shuffled(6, 7, pid, 1)) for pid in ("P01", "P02", "P03", "P04")}
    assert len(orders) > 1  # 4 draws from 720 orders: all equal has odds 1/720^3


def _study(**design: object) -> Study:
    return Study(
        name="s",
        participants=[Participant(id="P01", role="driver"), Participant(id="P02", role="cyclist")],
        conditions=[Condition(id="direct"), Condition(id="lagged")],
        design=Design(**design),  # type: ignore[arg-type]
    )


def test_plan_counterbalances_two_participants_over_two_blocks() -> None:
    trials = plan(_study(order="latin", blocks=2, practice=["direct"]))
    assert [t.id for t in trials] == ["t01", "t02", "t03", "t04", "t05"]
    assert trials[0].kind == PRACTICE and trials[0].conditions == {"P01": "direct", "P02": "direct"}
    main = [t for t in trials if t.kind == MAIN]
    # Williams n=2: rows AB and BA; P01 walks row 0, P02 row 1, in both blocks
    assert [t.conditions["P01"] for t in main] == ["direct", "lagged", "direct", "lagged"]
    assert [t.conditions["P02"] for t in main] == ["lagged", "direct", "lagged", "direct"]
    assert [t.block for t in main] == [1, 1, 2, 2]


def test_plan_repeats_and_session_counterbalance() -> None:
    trials = plan(_study(counterbalance="session", row=1, repeats=2))
    assert [t.conditions for t in trials] == [{"P01": "lagged", "P02": "lagged"}] * 2 + [
        {"P01": "direct", "P02": "direct"}
    ] * 2


def test_conditions_that_set_the_world_cannot_differ_within_a_trial() -> None:
    study = Study(
        name="s",
        participants=[Participant(id="P01", role="driver"), Participant(id="P02", role="cyclist")],
        conditions=[Condition(id="dry"), Condition(id="wet", scenario="crossing")],
    )
    assert "trial t01" in shared_conflict(study, plan(study))
    assert shared_conflict(_study(), plan(_study())) == ""


def test_digest_follows_the_file() -> None:
    assert digest(_study()) == digest(_study())
    assert digest(_study()) != digest(_study(blocks=2))
