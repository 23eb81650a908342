"""Carrying the humans inside SUMO, so NPCs brake, yield and queue for them.

Each ego becomes a remote-controlled SUMO actor, the way CARLA's co-simulation does it: a
vehicle added with an empty route and moved with `moveToXY(..., keepRoute=2)` every step
(SUMO then infers its speed from the motion), with speed and lane-change modes that leave
every decision to us; walkers become a person in a walking stage (only walking persons are
seen on crossings) moved with `person.moveToXY`. SUMO places a vehicle by its front bumper,
so the centre pose is shifted forward by half the length.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any

from carlaverse.traffic.engine import EgoPlacement
from carlaverse.traffic.sumo_demand import KIND_TYPES

log = logging.getLogger(__name__)

EGO_PREFIX = "@"  # SUMO ids of carried egos; NPC ids never start with it
KEEP_ROUTE_ANYWHERE = 2  # moveToXY: map to the nearest lane, ignoring the route
SPEED_MODE_NONE = 0  # no safe-speed, acceleration or right-of-way checks: we drive
LANE_CHANGE_NONE = 0  # no autonomous lane changes
RETRY_AFTER_S = 1.0  # [s] engine time before an ego that could not be placed is tried again


def sumo_id(node_id: str) -> str:
    return EGO_PREFIX + node_id


def sumo_angle_deg(yaw: float) -> float:
    """SUMO heading (degrees clockwise from north) of a yaw (radians, counter-clockwise from x)."""
    return (90.0 - math.degrees(yaw)) % 360.0


class EgoCarrier:
    """The egos currently carried in SUMO, kept in step with the placements each tick."""

    def __init__(self, ls: Any, match_radius_m: float = 10.0) -> None:
        self._ls = ls
        self._radius_m = match_radius_m
        self._carried: dict[str, bool] = {}  # node id -> is a person
        self._retry_at: dict[str, float] = {}  # node id -> engine time of the next attempt [s]
        self.failures = 0
        # The compiled call behind `vehicle.moveToXY` (its Python wrapper only forwards): a
        # frame less per ego and tick, hundreds of times a tick with a swarm.
        raw = getattr(ls, "_libsumo", None)
        self._move_vehicle = getattr(raw, "vehicle_moveToXY", None) or ls.vehicle.moveToXY

    @property
    def carrying(self) -> bool:
        return bool(self._carried)

    @property
    def vehicles(self) -> int:
        return sum(1 for person in self._carried.values() if not person)

    @property
    def persons(self) -> int:
        return sum(1 for person in self._carried.values() if person)

    def place(self, egos: Sequence[EgoPlacement], now_s: float) -> None:
        """Carry these egos at engine time `now_s`; drop the ones no longer among them."""
        egos = list(egos)  # columns (`EgoPlacements`) make their rows once, here
        wanted = {e.node_id for e in egos}
        for node_id in [n for n in self._carried if n not in wanted]:
            self.remove(node_id)
        for node_id in [n for n in self._retry_at if n not in wanted]:
            del self._retry_at[node_id]
        for ego in egos:
            if now_s >= self._retry_at.get(ego.node_id, -math.inf):
                self._place_one(ego, now_s)

    def remove(self, node_id: str) -> None:
        person = self._carried.pop(node_id, None)
        if person is None:
            return
        domain = self._ls.person if person else self._ls.vehicle
        try:
            domain.remove(sumo_id(node_id))
        except self._ls.TraCIException as exc:
            log.debug("ego %s was already gone from SUMO: %s", node_id, exc)

    def _place_one(self, ego: EgoPlacement, now_s: float) -> None:
        person = ego.actor_kind == "pedestrian"
        try:
            if self._carried.get(ego.node_id) is not person:
                self.remove(ego.node_id)
                self._add(ego, person)
            self._move(ego, person)
        except self._ls.TraCIException as exc:
            # Off the network, or its walk finished by SUMO: drop it, add it afresh a bit later.
            self.failures += 1
            first = ego.node_id not in self._retry_at
            (log.warning if first else log.debug)(
                "ego %s cannot be carried in SUMO (NPCs will not see it): %s", ego.node_id, exc
            )
            self._retry_at[ego.node_id] = now_s + RETRY_AFTER_S
            self.remove(ego.node_id)
            return
        self._retry_at.pop(ego.node_id, None)

    def _add(self, ego: EgoPlacement, person: bool) -> None:
        ls, sid = self._ls, sumo_id(ego.node_id)
        spec = KIND_TYPES.get(ego.actor_kind, KIND_TYPES["other"])
        if sid not in ls.vehicletype.getIDList():
            ls.vehicletype.copy(spec.base, sid)
            ls.vehicletype.setVehicleClass(sid, spec.vclass)
        ls.vehicletype.setLength(sid, max(ego.length, 0.1))
        ls.vehicletype.setWidth(sid, max(ego.width, 0.1))
        ls.vehicletype.setHeight(sid, max(ego.height, 0.1))
        if person:
            edge, pos, _lane = ls.simulation.convertRoad(ego.x, ego.y, False, "pedestrian")
            ls.person.add(sid, edge, pos, depart=-3, typeID=sid)
            ls.person.appendWalkingStage(sid, [edge], -1.0)
        else:
            ls.vehicle.add(sid, "", typeID=sid)
            ls.vehicle.setSpeedMode(sid, SPEED_MODE_NONE)
            ls.vehicle.setLaneChangeMode(sid, LANE_CHANGE_NONE)
        self._carried[ego.node_id] = person

    def _move(self, ego: EgoPlacement, person: bool) -> None:
        sid, angle = sumo_id(ego.node_id), sumo_angle_deg(ego.yaw)
        if person:
            self._ls.person.moveToXY(
                sid, "", ego.x, ego.y, angle, KEEP_ROUTE_ANYWHERE, self._radius_m
            )
            return
        half = ego.length / 2.0
        front_x = ego.x + half * math.cos(ego.yaw)
        front_y = ego.y + half * math.sin(ego.yaw)
        self._move_vehicle(
            sid, "", -1, front_x, front_y, angle, KEEP_ROUTE_ANYWHERE, self._radius_m
        )

    def clear(self) -> None:
        for node_id in list(self._carried):
            self.remove(node_id)
