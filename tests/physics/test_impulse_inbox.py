"""The impulse inbox both node loops share: validated, de-duplicated, released when due."""

from __future__ import annotations

import math

from carlaverse.messages import Impulse
from carlaverse.physics.impulse import MAX_IMPULSE_DV_MPS, SEEN_IMPULSES, ImpulseInbox

MASS_KG = 100.0


def impulse(seq: int, jx: float, t: float = 0.0) -> Impulse:
    return Impulse(seq, t, seq, (jx, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "npc", "car", 2.0)


def test_impulses_wait_for_their_time_and_leave_once() -> None:
    inbox = ImpulseInbox(MASS_KG)
    late, soon = impulse(1, 10.0, t=2.0), impulse(2, 10.0, t=1.0)
    inbox.accept([late, soon, soon])  # a re-delivered copy is one impulse
    assert inbox.due(0.5) == []
    assert inbox.due(1.0) == [soon]
    assert inbox.due(5.0) == [late]
    assert inbox.due(5.0) == []
    inbox.accept([late])  # delivered again after it applied: still remembered, not re-applied
    assert inbox.due(5.0) == [] and inbox.dropped == 0


def test_a_non_finite_or_impossible_impulse_is_counted_and_dropped() -> None:
    inbox = ImpulseInbox(MASS_KG)
    just_too_much = MASS_KG * MAX_IMPULSE_DV_MPS * 1.01  # [N·s]
    inbox.accept([impulse(1, math.nan), impulse(2, just_too_much), impulse(3, math.inf)])
    inbox.accept([impulse(4, MASS_KG * MAX_IMPULSE_DV_MPS)])  # exactly the limit is accepted
    assert inbox.dropped == 3
    assert [i.seq for i in inbox.due(0.0)] == [4]


def test_the_memory_of_seen_impulses_is_bounded() -> None:
    inbox = ImpulseInbox(MASS_KG)
    first = impulse(0, 1.0)
    inbox.accept([first, *(impulse(n, 1.0) for n in range(1, SEEN_IMPULSES + 1))])
    assert len(inbox.due(0.0)) == SEEN_IMPULSES + 1
    inbox.accept([first])  # forgotten after SEEN_IMPULSES newer ones: accepted again
    assert inbox.due(0.0) == [first]
