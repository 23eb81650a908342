"""Traffic lights: the engine's programs, scenario overrides, and when to publish the states.

States go out on `world/lights` whenever any light changes phase or state, and at
`status_rate_hz` regardless, each with the time remaining in its phase. The current state is
rebuilt every tick (a few dozen lights cost microseconds) so a late joiner's snapshot carries
an exact remaining time, not one up to a second stale.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from carlaverse.messages import LightsState, TrafficLight
from carlaverse.traffic.engine import LightPhase, LightReading, TrafficEngine
from carlaverse.traffic.scenario import LightOverride


def apply_overrides(engine: TrafficEngine, overrides: Sequence[LightOverride]) -> None:
    """Install the scenario's programs; a wrong light id or state length raises ValueError."""
    for o in overrides:
        phases = [LightPhase(p.duration_s, p.state) for p in o.phases]
        try:
            engine.set_light_program(o.id, phases, o.offset_s)
        except ValueError as exc:
            raise ValueError(f"lights: override for {o.id!r}: {exc}") from exc


class LightPublisher:
    """Reads the lights every tick and decides when a `LightsState` goes out."""

    def __init__(self, engine: TrafficEngine, status_rate_hz: float) -> None:
        self._engine = engine
        self._period_s = 1.0 / status_rate_hz
        self._sent_key: tuple[tuple[str, str, int], ...] | None = None
        self._sent_t = -math.inf
        self._seq = 0
        self.current: LightsState | None = None  # fresh every tick, for snapshots

    def tick(self, t: float, next_seq: Callable[[], int]) -> LightsState | None:
        """The message to publish at session time `t`, or None when nothing is due."""
        readings = self._engine.light_readings()
        if not readings:
            return None
        key = tuple((r.id, r.state, r.phase) for r in readings)
        due = key != self._sent_key or t - self._sent_t >= self._period_s - 1e-9
        if due:
            self._seq, self._sent_key, self._sent_t = next_seq(), key, t
        self.current = LightsState(self._seq, t, self._lights(readings))
        return self.current if due else None

    def _lights(self, readings: list[LightReading]) -> list[TrafficLight]:
        now = self._engine.time_s
        return [
            TrafficLight(r.id, r.state, r.phase, max(0.0, r.next_switch_s - now)) for r in readings
        ]
