"""Collision impulses on a planar rigid body.

The authority decides the impulse J (world frame, N·s) and the contact point; the node only
applies it: Δv = J/m at the centre of gravity and Δω_z = (r × J)_z / I_z, r from the CG to
the contact point. Vertical components are left to the motion cue (the chassis is planar).

Impulses reach a node's loop ahead of their time stamp; an `ImpulseInbox` checks each one,
drops an identical re-delivery, and hands them out when the loop's clock reaches them.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from carlaverse.messages import Impulse
from carlaverse.physics.single_track import ChassisState

log = logging.getLogger(__name__)

MAX_IMPULSE_DV_MPS = 50.0  # [m/s] a larger Δv from one impulse is a bad message
SEEN_IMPULSES = 256  # impulses remembered to drop a re-delivered copy


@dataclass(frozen=True, slots=True)
class ImpulseResponse:
    """What one impulse did to the body, for haptics and motion cues."""

    dvx_body: float  # [m/s] forward velocity change
    dvy_body: float  # [m/s] leftward velocity change
    dyaw_rate: float  # [rad/s]
    dvz: float  # [m/s] vertical component J_z/m (not applied to the planar chassis)

    def magnitude(self) -> float:
        """|Δv| [m/s] including the vertical part."""
        return math.sqrt(self.dvx_body**2 + self.dvy_body**2 + self.dvz**2)


def apply_impulse(
    state: ChassisState,
    impulse_ns: tuple[float, float, float],
    point_m: tuple[float, float, float],
    mass_kg: float,
    yaw_inertia_kgm2: float,
) -> ImpulseResponse:
    """Change `state` by the impulse J applied at `point_m` (both world frame)."""
    jx, jy, jz = impulse_ns
    rx, ry = point_m[0] - state.x, point_m[1] - state.y
    c, s = math.cos(state.yaw), math.sin(state.yaw)
    response = ImpulseResponse(
        dvx_body=(jx * c + jy * s) / mass_kg,
        dvy_body=(-jx * s + jy * c) / mass_kg,
        dyaw_rate=(rx * jy - ry * jx) / yaw_inertia_kgm2,
        dvz=jz / mass_kg,
    )
    state.vx += response.dvx_body
    state.vy += response.dvy_body
    state.yaw_rate += response.dyaw_rate
    return response


class ImpulseInbox:
    """A body's pending impulses: validated, de-duplicated, released when their time comes."""

    def __init__(self, mass_kg: float) -> None:
        self.mass_kg = mass_kg  # [kg] to judge an impulse by the Δv it would cause
        self.dropped = 0  # bad impulses (non-finite or an impossible Δv)
        self._pending: list[Impulse] = []
        self._seen: deque[Impulse] = deque(maxlen=SEEN_IMPULSES)

    def accept(self, impulses: Iterable[Impulse]) -> None:
        for impulse in impulses:
            self._accept(impulse)

    def due(self, now: float) -> list[Impulse]:
        """The impulses stamped at or before `now` [s session time], removed from the inbox."""
        if not self._pending:
            return []
        due = [i for i in self._pending if i.t <= now]
        if due:
            self._pending = [i for i in self._pending if i.t > now]
        return due

    def _accept(self, impulse: Impulse) -> None:
        # The NodeClient already drops re-deliveries by what identifies an impulse (authority
        # instance, contact id); here only an identical message twice is one. Never by `seq`
        # alone: it restarts with the authority, and the new one's first impulse must apply.
        if impulse in self._seen:
            return
        values = (*impulse.impulse, *impulse.point, impulse.t)
        dv = math.hypot(*impulse.impulse) / self.mass_kg  # [m/s]
        if not all(math.isfinite(v) for v in values) or dv > MAX_IMPULSE_DV_MPS:
            self.dropped += 1
            log.warning("dropped impulse seq %d: non-finite or Δv %.1f m/s", impulse.seq, dv)
            return
        self._seen.append(impulse)
        self._pending.append(impulse)
