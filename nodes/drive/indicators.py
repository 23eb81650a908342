"""The indicator state machine (paper, figure "Indicator System State Machine", normative).

Transitions fire on rising edges of four events: hazard light HL, left indicator LI, right
indicator RI and indicator reset IR. The paper's rules:
- LI cancels RI and vice versa; pressing the active direction again switches it off.
- Hazard can be overridden temporarily by an indicator, and returns when that indicator is
  switched off (HAZARD → HAZARD_LEFT → HAZARD on LI, LI).
- IR resets a direction only while lane-change assist (LCA) is active; otherwise it is
  ignored. A reset of an indicator that overrides the hazard returns to the hazard.
Our choices where the paper is silent: HL while a plain indicator flashes starts the hazard
(the indicator is forgotten); HL while the hazard is overridden switches the hazard off and
leaves the overriding indicator on; IR never touches the hazard itself.

`TRANSITIONS` lists every (state, event) pair explicitly; IR's entries are its targets when
LCA is active, and the guard in `next_state` holds the state otherwise.
"""

from __future__ import annotations

import enum
from types import MappingProxyType

from carlaverse.messages import LIGHT_LEFT_BLINKER, LIGHT_RIGHT_BLINKER

BLINK_PERIOD_S = 0.667  # [s] 90 flashes per minute (UN R48 allows 60-120)


class IndicatorState(enum.Enum):
    OFF = "off"
    LEFT = "left"
    RIGHT = "right"
    HAZARD = "hazard"
    HAZARD_LEFT = "hazard_left"  # hazard overridden by the left indicator
    HAZARD_RIGHT = "hazard_right"


class IndicatorEvent(enum.Enum):
    HL = "hazard"
    LI = "indicator_left"
    RI = "indicator_right"
    IR = "indicator_reset"


S, E = IndicatorState, IndicatorEvent

TRANSITIONS = MappingProxyType(
    {
        (S.OFF, E.HL): S.HAZARD,
        (S.OFF, E.LI): S.LEFT,
        (S.OFF, E.RI): S.RIGHT,
        (S.OFF, E.IR): S.OFF,
        (S.LEFT, E.HL): S.HAZARD,
        (S.LEFT, E.LI): S.OFF,
        (S.LEFT, E.RI): S.RIGHT,
        (S.LEFT, E.IR): S.OFF,  # only with LCA active
        (S.RIGHT, E.HL): S.HAZARD,
        (S.RIGHT, E.LI): S.LEFT,
        (S.RIGHT, E.RI): S.OFF,
        (S.RIGHT, E.IR): S.OFF,  # only with LCA active
        (S.HAZARD, E.HL): S.OFF,
        (S.HAZARD, E.LI): S.HAZARD_LEFT,
        (S.HAZARD, E.RI): S.HAZARD_RIGHT,
        (S.HAZARD, E.IR): S.HAZARD,
        (S.HAZARD_LEFT, E.HL): S.LEFT,
        (S.HAZARD_LEFT, E.LI): S.HAZARD,
        (S.HAZARD_LEFT, E.RI): S.HAZARD_RIGHT,
        (S.HAZARD_LEFT, E.IR): S.HAZARD,  # only with LCA active
        (S.HAZARD_RIGHT, E.HL): S.RIGHT,
        (S.HAZARD_RIGHT, E.LI): S.HAZARD_LEFT,
        (S.HAZARD_RIGHT, E.RI): S.HAZARD,
        (S.HAZARD_RIGHT, E.IR): S.HAZARD,  # only with LCA active
    }
)

# Which lamps flash in each state: (left, right).
LAMPS = MappingProxyType(
    {
        S.OFF: (False, False),
        S.LEFT: (True, False),
        S.RIGHT: (False, True),
        S.HAZARD: (True, True),
        S.HAZARD_LEFT: (True, False),
        S.HAZARD_RIGHT: (False, True),
    }
)

# What other participants see (messages.EgoState.indicator).
VISIBLE = MappingProxyType(
    {
        S.OFF: "off",
        S.LEFT: "left",
        S.RIGHT: "right",
        S.HAZARD: "hazard",
        S.HAZARD_LEFT: "left",
        S.HAZARD_RIGHT: "right",
    }
)


def next_state(state: IndicatorState, event: IndicatorEvent, lca_active: bool) -> IndicatorState:
    """The state after one rising edge; IR is ignored unless lane-change assist is active."""
    if event is E.IR and not lca_active:
        return state
    return TRANSITIONS[(state, event)]


class Indicators:
    """The machine plus the flasher. Feed it the rising edges of each loop tick."""

    def __init__(self, blink_period_s: float = BLINK_PERIOD_S) -> None:
        self.state = S.OFF
        self.blink_period_s = blink_period_s
        self._phase_s = 0.0

    def handle(self, pressed: frozenset[str] | set[str], lca_active: bool) -> None:
        """Apply this tick's rising edges (action names) in a fixed order: HL, LI, RI, IR."""
        if not pressed:
            return
        for event in E:
            if event.value in pressed:
                before = self.state
                self.state = next_state(self.state, event, lca_active)
                if before is S.OFF and self.state is not S.OFF:
                    self._phase_s = 0.0  # the first flash comes at once, as in a car

    def advance(self, dt: float) -> bool:
        """Move the flasher on by dt [s]; True while the lamps are lit (50 % duty)."""
        if self.state is S.OFF:
            self._phase_s = 0.0
            return False
        self._phase_s = (self._phase_s + dt) % self.blink_period_s
        return self._phase_s < 0.5 * self.blink_period_s

    def light_bits(self) -> int:
        """LIGHT_*_BLINKER bits of the active indicators (set while active, not per flash)."""
        left, right = LAMPS[self.state]
        return (LIGHT_LEFT_BLINKER if left else 0) | (LIGHT_RIGHT_BLINKER if right else 0)

    def visible(self) -> str:
        return VISIBLE[self.state]
