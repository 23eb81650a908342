"""A study's schedule: which condition each participant is in, trial by trial.

Orders (`Design.order`):
- `latin`: rows of a balanced Latin square (Williams 1949). For n conditions, n even: n rows
  in which every condition holds every position once and every condition follows every
  other exactly once, so first-order carry-over is balanced. n odd: no single square does
  that, so the square and its mirror image are used (2n rows; each ordered pair adjacent
  twice). Participant k walks row k mod rows (or every participant row `Design.row`).
- `shuffle`: a seeded shuffle of the conditions per participant and block, reproducible
  (the generator is seeded from the study seed, the participant and the block).
- `fixed`: the conditions in the order the file lists them.

Practice trials come first, the same for everyone; then `blocks` passes through the
conditions, each condition `repeats` trials in a row.
"""

from __future__ import annotations

import hashlib
import random

import msgspec

from carlaverse.study.study_file import Condition, Study

MAIN, PRACTICE = "main", "practice"


class Trial(msgspec.Struct, frozen=True):
    """One trial of the schedule: one session with every participant."""

    id: str  # t01, t02, ... in running order
    index: int  # 0-based position in the schedule
    kind: str  # main | practice
    block: int  # 1-based; 0 for practice
    conditions: dict[str, str]  # participant id -> condition id


def williams_rows(n: int) -> list[list[int]]:
    """Rows of a balanced Latin square of `n` conditions (0..n-1): n rows for n even, 2n
    (the cyclic square and its mirror) for n odd."""
    if n < 1:
        raise ValueError(f"a Latin square needs at least one condition, got {n}")
    # First row 0, 1, n-1, 2, n-2, ...: its successive differences are all distinct mod n.
    first = [0]
    low, high = 1, n - 1
    for step in range(1, n):
        if step % 2 == 1:
            first.append(low)
            low += 1
        else:
            first.append(high)
            high -= 1
    rows = [[(c + shift) % n for c in first] for shift in range(n)]
    if n % 2 == 1:
        rows += [list(reversed(row)) for row in rows]
    return rows


def shuffled(n: int, seed: int, participant: str, block: int) -> list[int]:
    """0..n-1 shuffled by a generator seeded from (seed, participant, block), reproducible
    across runs and Python versions (the seed goes through SHA-256, not `hash`)."""
    digest = hashlib.sha256(f"{seed}/{participant}/{block}".encode()).digest()
    order = list(range(n))
    random.Random(int.from_bytes(digest[:8], "big")).shuffle(order)
    return order


def condition_order(study: Study, participant_index: int, block: int) -> list[int]:
    """The condition indices participant `participant_index` walks in `block` (1-based)."""
    design, n = study.design, len(study.conditions)
    row = participant_index if design.counterbalance == "participant" else design.row
    if design.order == "latin":
        rows = williams_rows(n)
        return rows[row % len(rows)]
    if design.order == "shuffle":
        who = study.participants[participant_index].id
        key = who if design.counterbalance == "participant" else f"row{design.row}"
        return shuffled(n, design.seed, key, block)
    return list(range(n))


def plan(study: Study) -> list[Trial]:
    """Every trial in running order."""
    trials: list[Trial] = []
    everyone = [p.id for p in study.participants]
    for name in study.design.practice:
        trials.append(_trial(len(trials), PRACTICE, 0, dict.fromkeys(everyone, name)))
    for block in range(1, study.design.blocks + 1):
        orders = [condition_order(study, i, block) for i in range(len(everyone))]
        for position in range(len(study.conditions)):
            chosen = {
                pid: study.conditions[orders[i][position]].id for i, pid in enumerate(everyone)
            }
            for _ in range(study.design.repeats):
                trials.append(_trial(len(trials), MAIN, block, chosen))
    return trials


def _trial(index: int, kind: str, block: int, conditions: dict[str, str]) -> Trial:
    return Trial(f"t{index + 1:02d}", index, kind, block, conditions)


def shared_conflict(study: Study, trials: list[Trial]) -> str:
    """Why a trial cannot run as one session ("" if every trial can): participants of one
    trial in conditions that set the world (scenario, seed, overrides) differently."""
    by_id = {c.id: c for c in study.conditions}
    for trial in trials:
        worlds = {_world(by_id[name]) for name in trial.conditions.values()}
        if len(worlds) > 1:
            who = ", ".join(f"{p} in {c}" for p, c in trial.conditions.items())
            return (
                f"trial {trial.id} puts {who}, and these conditions set the world differently "
                "(scenario, seed or scenario_override): one session has one world; vary only "
                "latency and node_config per participant, or set design.counterbalance: session"
            )
    return ""


def _world(condition: Condition) -> bytes:
    return msgspec.json.encode([condition.scenario, condition.seed, condition.scenario_override])


def world_condition(study: Study, trial: Trial) -> Condition:
    """The condition that sets the trial's world (all of its participants' agree on it)."""
    first = next(iter(trial.conditions.values()))
    return next(c for c in study.conditions if c.id == first)


def digest(study: Study) -> str:
    """A fingerprint of the study as decoded: a log begun under another file is not resumed."""
    return hashlib.sha256(msgspec.json.encode(study)).hexdigest()[:16]
