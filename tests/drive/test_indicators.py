"""The indicator state machine, checked pair by pair against the paper's rules."""

from __future__ import annotations

import itertools

import pytest
from carlaverse_nodes.drive.indicators import (
    TRANSITIONS,
    IndicatorEvent,
    Indicators,
    IndicatorState,
    next_state,
)

from carlaverse.messages import LIGHT_LEFT_BLINKER, LIGHT_RIGHT_BLINKER

S, E = IndicatorState, IndicatorEvent

# Expected next state for every (state, event, LCA active), written out from the paper's text
# and figure caption, one reason per group:
EXPECTED = {
    # From OFF: each switch starts its function; IR has nothing to reset.
    (S.OFF, E.HL, False): S.HAZARD, (S.OFF, E.HL, True): S.HAZARD,
    (S.OFF, E.LI, False): S.LEFT, (S.OFF, E.LI, True): S.LEFT,
    (S.OFF, E.RI, False): S.RIGHT, (S.OFF, E.RI, True): S.RIGHT,
    (S.OFF, E.IR, False): S.OFF, (S.OFF, E.IR, True): S.OFF,
    # LEFT: LI again switches it off; RI cancels it ("LI cancels RI and vice versa");
    # IR resets the direction only with LCA active.
    (S.LEFT, E.HL, False): S.HAZARD, (S.LEFT, E.HL, True): S.HAZARD,
    (S.LEFT, E.LI, False): S.OFF, (S.LEFT, E.LI, True): S.OFF,
    (S.LEFT, E.RI, False): S.RIGHT, (S.LEFT, E.RI, True): S.RIGHT,
    (S.LEFT, E.IR, False): S.LEFT, (S.LEFT, E.IR, True): S.OFF,
    # RIGHT: the mirror image.
    (S.RIGHT, E.HL, False): S.HAZARD, (S.RIGHT, E.HL, True): S.HAZARD,
    (S.RIGHT, E.LI, False): S.LEFT, (S.RIGHT, E.LI, True): S.LEFT,
    (S.RIGHT, E.RI, False): S.OFF, (S.RIGHT, E.RI, True): S.OFF,
    (S.RIGHT, E.IR, False): S.RIGHT, (S.RIGHT, E.IR, True): S.OFF,
    # HAZARD: HL switches it off; an indicator overrides it temporarily; IR has no direction.
    (S.HAZARD, E.HL, False): S.OFF, (S.HAZARD, E.HL, True): S.OFF,
    (S.HAZARD, E.LI, False): S.HAZARD_LEFT, (S.HAZARD, E.LI, True): S.HAZARD_LEFT,
    (S.HAZARD, E.RI, False): S.HAZARD_RIGHT, (S.HAZARD, E.RI, True): S.HAZARD_RIGHT,
    (S.HAZARD, E.IR, False): S.HAZARD, (S.HAZARD, E.IR, True): S.HAZARD,
    # HAZARD_LEFT: switching the indicator off brings the hazard back; RI cancels LI but
    # still overrides the hazard; HL ends the hazard, the indicator stays; IR (LCA only)
    # resets the direction, so the hazard returns.
    (S.HAZARD_LEFT, E.HL, False): S.LEFT, (S.HAZARD_LEFT, E.HL, True): S.LEFT,
    (S.HAZARD_LEFT, E.LI, False): S.HAZARD, (S.HAZARD_LEFT, E.LI, True): S.HAZARD,
    (S.HAZARD_LEFT, E.RI, False): S.HAZARD_RIGHT, (S.HAZARD_LEFT, E.RI, True): S.HAZARD_RIGHT,
    (S.HAZARD_LEFT, E.IR, False): S.HAZARD_LEFT, (S.HAZARD_LEFT, E.IR, True): S.HAZARD,
    # HAZARD_RIGHT: the mirror image.
    (S.HAZARD_RIGHT, E.HL, False): S.RIGHT, (S.HAZARD_RIGHT, E.HL, True): S.RIGHT,
    (S.HAZARD_RIGHT, E.LI, False): S.HAZARD_LEFT, (S.HAZARD_RIGHT, E.LI, True): S.HAZARD_LEFT,
    (S.HAZARD_RIGHT, E.RI, False): S.HAZARD, (S.HAZARD_RIGHT, E.RI, True): S.HAZARD,
    (S.HAZARD_RIGHT, E.IR, False): S.HAZARD_RIGHT, (S.HAZARD_RIGHT, E.IR, True): S.HAZARD,
}  # fmt: skip

ALL_PAIRS = list(itertools.product(S, E, (False, True)))


def test_the_expected_table_covers_every_state_event_and_guard() -> None:
    assert set(EXPECTED) == set(ALL_PAIRS)
    assert set(TRANSITIONS) == {(s, e) for s, e in itertools.product(S, E)}


@pytest.mark.parametrize(("state", "event", "lca"), ALL_PAIRS)
def test_every_transition(state: IndicatorState, event: IndicatorEvent, lca: bool) -> None:
    assert next_state(state, event, lca) is EXPECTED[(state, event, lca)]


def press(machine: Indicators, *actions: str, lca: bool = False) -> IndicatorState:
    for action in actions:
        machine.handle({action}, lca)
    return machine.state


def test_hazard_returns_after_a_temporary_indicator() -> None:
    m = Indicators()
    assert press(m, "hazard", "indicator_left") is S.HAZARD_LEFT
    assert m.visible() == "left"
    assert m.light_bits() == LIGHT_LEFT_BLINKER  # only the overriding side flashes
    assert press(m, "indicator_left") is S.HAZARD
    assert m.light_bits() == LIGHT_LEFT_BLINKER | LIGHT_RIGHT_BLINKER


def test_reset_needs_lane_change_assist() -> None:
    m = Indicators()
    assert press(m, "indicator_right", "indicator_reset") is S.RIGHT
    assert press(m, "indicator_reset", lca=True) is S.OFF


def test_events_of_one_tick_apply_in_a_fixed_order() -> None:
    m = Indicators()
    # HL before LI: hazard on, then overridden by the left indicator.
    m.handle({"indicator_left", "hazard"}, False)
    assert m.state is S.HAZARD_LEFT


def test_flasher_lights_at_once_with_half_duty() -> None:
    m = Indicators(blink_period_s=0.6)
    assert m.advance(0.001) is False  # off: dark
    press(m, "indicator_left")
    lit = [m.advance(0.001) for _ in range(1200)]  # two periods at 1 kHz
    assert lit[0] is True  # first flash immediately, as in a car
    assert sum(lit) == pytest.approx(600, abs=2)  # 50 % duty
    assert lit[297] is True and lit[301] is False  # on for the first half period (±1 tick)
