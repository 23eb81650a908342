"""Touchscreen taps in the control loop: each becomes the button `touch:<action>` for one tick.

The web HMI's commands reach the loop process on its event queue (like impulses and
overrides). There a tap is held down for one tick and released the next, so `Controls` sees
one rising edge per tap — the same path a key or a wheel button takes. Taps wait their turn:
two quick taps of `lights_next` are two edges, not one.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from carlaverse_nodes.drive.controls import TOUCH_PREFIX

MAX_PENDING = 32  # taps queued beyond this are dropped (a stuck page must not pile up)


@dataclass(frozen=True)
class TouchPress:
    """A touchscreen tap on its way to the control loop."""

    action: str


class TouchButtons:
    """Taps → one-tick button presses, one tap per two ticks (down, then up)."""

    def __init__(self) -> None:
        self._pending: deque[str] = deque()
        self._down: str | None = None
        self.dropped = 0

    def tap(self, action: str) -> None:
        if len(self._pending) >= MAX_PENDING:
            self.dropped += 1
            return
        self._pending.append(TOUCH_PREFIX + action)

    def buttons(self) -> dict[str, bool] | None:
        """This tick's touch button, or None when no touch button is down."""
        if self._down is not None:
            self._down = None  # released for a tick, so the next tap is a fresh edge
            return None
        if not self._pending:
            return None
        self._down = self._pending.popleft()
        return {self._down: True}
