"""ADAS override arbitration: external programs drive alongside the human (paper, "Control
and ADAS Interfaces"; docs/architecture.md §3).

An override (carlaverse.messages.Override) comes from the fabric or the local API. Rules:
- cruise control replaces the pedal inputs with a speed PI controller's;
- lane keeping adds a steering torque (felt through the FFB wheel; optionally also turned
  into a steering offset for setups without one);
- the driver's brake always wins over cruise control: while the brake pedal is pressed the
  driver's pedals pass through and the controller's integrator is reset;
- an override lapses at its `expires_t` (session time), when its source withdraws it
  (`active: false`), or — if `override_timeout_s` is set — when not refreshed in time;
- per source, an override with a sequence number not newer than the last one is a
  duplicate or a reordering and is dropped (delivery is at-least-once).
Bad values are counted and dropped, never raised into the loop.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.messages import Override

log = logging.getLogger(__name__)

NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Pedal = Annotated[float, msgspec.Meta(ge=0, le=1)]
MAX_CRUISE_SPEED_MPS = 70.0  # [m/s] 252 km/h: anything above is a bad message


class AdasParams(StrictStruct):
    """The `adas:` section of a drive config."""

    cruise_kp_per_mps: NonNegative = 0.3  # pedal per m/s of speed error
    cruise_ki_per_m: NonNegative = 0.05  # pedal per (m/s · s) of accumulated error
    cruise_max_throttle: Pedal = 1.0
    cruise_max_brake: Pedal = 0.4  # cruise control brakes gently; the driver brakes hard
    cruise_coast_band: Pedal = 0.02  # |u| below this: neither pedal (no lamp flicker)
    driver_brake_threshold: Pedal = 0.05  # driver's brake above this cancels cruise output
    lane_keep_max_torque_nm: NonNegative = 4.0  # clamp on injected steering torque [N·m]
    lane_keep_steer_per_nm: NonNegative = 0.0  # steer input per N·m when no FFB wheel
    override_timeout_s: NonNegative = 0.0  # 0: an override holds until it expires/withdraws


@dataclass(slots=True)
class AdasState:
    """What the ADAS layer is doing this tick, for telemetry and the recording."""

    sources: str = ""  # active override sources, comma-separated; "" = human alone
    cruise_active: bool = False  # cruise control is driving the pedals this tick
    cruise_speed_mps: float = 0.0
    lane_keep_torque_nm: float = 0.0  # + = toward the left
    driver_brake_override: bool = False  # the driver's brake is overruling cruise control


@dataclass(slots=True)
class _Held:
    override: Override
    received: float  # [s] session time of arrival


class AdasArbiter:
    def __init__(self, params: AdasParams) -> None:
        self.params = params
        self._active: dict[str, _Held] = {}
        self._last_seq: dict[str, int] = {}
        self._integral = 0.0  # [m] speed-error integral of the cruise PI
        self.rejected = 0  # malformed or out-of-range overrides dropped
        self.duplicates = 0  # repeated or reordered overrides dropped
        self.state = AdasState()

    def submit(self, override: Override, now: float) -> bool:
        """Take one override (fabric or local API). Returns False when it was dropped."""
        problem = _problem(override)
        if problem:
            self.rejected += 1
            log.warning("dropped ADAS override from %r: %s", override.source, problem)
            return False
        last = self._last_seq.get(override.source)
        if last is not None and override.seq <= last:
            self.duplicates += 1
            return False
        self._last_seq[override.source] = override.seq
        if override.active:
            self._active[override.source] = _Held(override, now)
        else:
            self._active.pop(override.source, None)
        return True

    def apply(
        self, steer: float, throttle: float, brake: float, speed_mps: float, dt: float, now: float
    ) -> tuple[float, float, float]:
        """Arbitrate one tick: returns (steer, throttle, brake) and updates `state`."""
        if not self._active:
            self._integral = 0.0
            if self.state.sources:
                self.state = AdasState()
            return steer, throttle, brake
        self._expire(now)
        cruise = self._latest("cruise_speed_mps")
        lane = self._latest("lane_keep_torque_nm")
        p = self.params
        torque = 0.0
        if lane is not None and lane.lane_keep_torque_nm is not None:
            limit = p.lane_keep_max_torque_nm
            torque = max(-limit, min(limit, lane.lane_keep_torque_nm))
            steer = max(-1.0, min(1.0, steer + p.lane_keep_steer_per_nm * torque))
        driver_brakes = brake > p.driver_brake_threshold
        cruising = cruise is not None and not driver_brakes
        if cruising and cruise is not None:
            throttle, brake = self._cruise(cruise.cruise_speed_mps or 0.0, speed_mps, dt)
        else:
            self._integral = 0.0
        target = cruise.cruise_speed_mps if cruise is not None else None
        self.state = AdasState(
            sources=",".join(sorted(self._active)),
            cruise_active=cruising,
            cruise_speed_mps=target or 0.0,
            lane_keep_torque_nm=torque,
            driver_brake_override=cruise is not None and driver_brakes,
        )
        return steer, throttle, brake

    def _cruise(self, target: float, speed: float, dt: float) -> tuple[float, float]:
        p = self.params
        error = target - speed
        u = p.cruise_kp_per_mps * error + p.cruise_ki_per_m * self._integral
        if -p.cruise_max_brake < u < p.cruise_max_throttle:
            self._integral += error * dt  # anti-windup: integrate only while unsaturated
        if u > p.cruise_coast_band:
            return min(u, p.cruise_max_throttle), 0.0
        if u < -p.cruise_coast_band:
            return 0.0, min(-u, p.cruise_max_brake)
        return 0.0, 0.0

    def _expire(self, now: float) -> None:
        timeout = self.params.override_timeout_s
        lapsed = [
            source
            for source, held in self._active.items()
            if (held.override.expires_t is not None and now >= held.override.expires_t)
            or (timeout > 0.0 and now - held.received > timeout)
        ]
        for source in lapsed:
            del self._active[source]

    def _latest(self, field: str) -> Override | None:
        """The most recent active override that sets `field`."""
        best: Override | None = None
        for held in self._active.values():
            o = held.override
            if getattr(o, field) is not None and (
                best is None or (o.t, o.seq) > (best.t, best.seq)
            ):
                best = o
        return best


def _problem(o: Override) -> str:
    """Why an override cannot be used, or "" when it can."""
    if not o.source:
        return "empty source"
    if not math.isfinite(o.t) or (o.expires_t is not None and not math.isfinite(o.expires_t)):
        return "non-finite time"
    v = o.cruise_speed_mps
    if v is not None and not (math.isfinite(v) and 0.0 <= v <= MAX_CRUISE_SPEED_MPS):
        return f"cruise_speed_mps={v!r} outside 0..{MAX_CRUISE_SPEED_MPS} m/s"
    torque = o.lane_keep_torque_nm
    if torque is not None and not math.isfinite(torque):
        return f"lane_keep_torque_nm={torque!r} is not finite"
    return ""
