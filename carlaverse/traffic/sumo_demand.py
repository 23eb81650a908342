"""NPC demand for SUMO: vehicle types, scripted NPCs, and random traffic kept at a target count.

Random routes are drawn from a `random.Random` seeded by the scenario and routed by SUMO
itself (`findRoute`, `findIntermodalRoute`), so the same scenario and seed give the same
traffic. Vehicles that arrive are replaced at the next top-up, so a session of any length
keeps its population.
"""

from __future__ import annotations

import logging
import random
from dataclasses import dataclass
from typing import Any

from carlaverse.traffic.scenario import ScriptedPedestrian, ScriptedVehicle, Traffic

log = logging.getLogger(__name__)

ROUTE_TRIES = 12  # random origin/destination pairs tried per NPC before giving up this round


@dataclass(frozen=True, slots=True)
class KindType:
    """How an actor kind looks in SUMO."""

    vclass: str
    base: str  # SUMO built-in type copied from
    length: float  # [m]
    width: float  # [m]
    height: float  # [m]
    max_speed: float  # [m/s]


KIND_TYPES: dict[str, KindType] = {
    "car": KindType("passenger", "DEFAULT_VEHTYPE", 4.5, 1.8, 1.5, 50.0),
    "van": KindType("delivery", "DEFAULT_VEHTYPE", 5.2, 2.0, 2.2, 38.0),
    "truck": KindType("truck", "DEFAULT_VEHTYPE", 9.0, 2.5, 3.4, 25.0),
    "bus": KindType("bus", "DEFAULT_VEHTYPE", 12.0, 2.5, 3.2, 25.0),
    "motorcycle": KindType("motorcycle", "DEFAULT_VEHTYPE", 2.2, 0.9, 1.5, 45.0),
    "bicycle": KindType("bicycle", "DEFAULT_BIKETYPE", 1.8, 0.65, 1.7, 7.0),
    "other": KindType("passenger", "DEFAULT_VEHTYPE", 4.5, 1.8, 1.5, 50.0),
    "pedestrian": KindType("pedestrian", "DEFAULT_PEDTYPE", 0.3, 0.5, 1.75, 1.5),
}


def npc_type_id(kind: str) -> str:
    return f"npc.{kind}"


def define_types(ls: Any) -> dict[str, str]:
    """Create one SUMO type per actor kind; returns SUMO type id -> actor kind."""
    types = {}
    for kind, spec in KIND_TYPES.items():
        tid = npc_type_id(kind)
        ls.vehicletype.copy(spec.base, tid)
        ls.vehicletype.setVehicleClass(tid, spec.vclass)
        ls.vehicletype.setLength(tid, spec.length)
        ls.vehicletype.setWidth(tid, spec.width)
        ls.vehicletype.setHeight(tid, spec.height)
        ls.vehicletype.setMaxSpeed(tid, spec.max_speed)
        types[tid] = kind
    return types


class DemandKeeper:
    """Adds scripted NPCs once and keeps random NPC vehicles and pedestrians at their counts."""

    def __init__(self, ls: Any, traffic: Traffic, seed: int, step_length_s: float) -> None:
        self._ls = ls
        self._traffic = traffic
        self._step_s = step_length_s
        # SUMO lets a vehicle decide every action step, counted from its departure. Vehicles
        # added together would all decide on the same step (a 5× spike in step time at 500
        # vehicles), so their departures are spread over one action step.
        self._spread = max(1, round(traffic.action_step_s / step_length_s))
        self._added = 0
        self._scheduled: list[float] = []  # [s] departure times of vehicles not yet due
        self._rng = random.Random(seed)
        self._counter = 0
        self._scripted = {v.id for v in traffic.scripted_vehicles} | {
            p.id for p in traffic.scripted_pedestrians
        }
        self._triggered: list[ScriptedVehicle] = []  # added later by scenario triggers
        self._vehicle_edges = _edges_allowing(ls, "passenger")
        self._bike_edges = _edges_allowing(ls, "bicycle")
        self._walk_edges = _edges_allowing(ls, "pedestrian")
        kinds = [(k, w) for k, w in traffic.vehicles.mix.items() if w > 0]
        self._kinds = [k for k, _ in kinds]
        self._weights = [w for _, w in kinds]
        self.failed_routes = 0

    def add_scripted(self) -> None:
        for vehicle in self._traffic.scripted_vehicles:
            self._add_scripted_vehicle(vehicle)
        for person in self._traffic.scripted_pedestrians:
            self._add_scripted_pedestrian(person)

    def add_now(self, vehicle: ScriptedVehicle) -> None:
        """A scripted vehicle that departs now (a trigger's spawn); not counted as traffic."""
        if vehicle.id in self._scripted or vehicle.id in self._ls.vehicle.getIDList():
            raise ValueError(f"an NPC with id {vehicle.id!r} exists already")
        self._scripted.add(vehicle.id)
        self._triggered.append(vehicle)
        self._add_scripted_vehicle(vehicle)

    def top_up(self, carried_vehicles: int, carried_persons: int) -> None:
        """Add random NPCs until the counts are met (egos carried in SUMO do not count)."""
        ls = self._ls
        now = ls.simulation.getTime()
        self._scheduled = [d for d in self._scheduled if d > now + 1e-9]
        waiting = len(ls.simulation.getPendingVehicles()) + len(self._scheduled)
        vehicles = ls.vehicle.getIDCount() + waiting - carried_vehicles - self._scripted_alive()
        for _ in range(max(0, self._traffic.vehicles.count - vehicles)):
            self._add_random_vehicle()
        persons = ls.person.getIDCount() - carried_persons - self._scripted_walking()
        for _ in range(max(0, self._traffic.pedestrians.count - persons)):
            self._add_random_pedestrian()

    def _scripted_alive(self) -> int:
        ids = self._ls.vehicle.getIDList()
        scripted = [*self._traffic.scripted_vehicles, *self._triggered]
        return sum(1 for v in scripted if v.id in ids)

    def _scripted_walking(self) -> int:
        ids = self._ls.person.getIDList()
        return sum(1 for p in self._traffic.scripted_pedestrians if p.id in ids)

    def _next_id(self, prefix: str) -> str:
        while True:
            self._counter += 1
            candidate = f"{prefix}{self._counter}"
            if candidate not in self._scripted:
                return candidate

    def _add_random_vehicle(self) -> None:
        if not self._kinds:
            return
        kind = self._rng.choices(self._kinds, self._weights)[0]
        edges = self._bike_edges if kind == "bicycle" else self._vehicle_edges
        route = self._random_route(edges, npc_type_id(kind))
        if route is None:
            return
        vid = self._next_id("v")
        self._added += 1
        depart = self._ls.simulation.getTime() + (self._added % self._spread) * self._step_s
        self._scheduled.append(depart)
        self._ls.route.add(f"r.{vid}", route)
        self._ls.vehicle.add(
            vid, f"r.{vid}", typeID=npc_type_id(kind), depart=f"{depart:.3f}",
            departLane="best", departPos="random_free", departSpeed="avg",
        )  # fmt: skip

    def _random_route(self, edges: list[str], type_id: str) -> list[str] | None:
        minimum = self._traffic.vehicles.min_route_edges
        for _ in range(ROUTE_TRIES if len(edges) > 1 else 0):
            origin, destination = self._rng.sample(edges, 2)
            found = self._ls.simulation.findRoute(origin, destination, vType=type_id)
            if len(found.edges) >= minimum:
                return list(found.edges)
        self.failed_routes += 1
        return None

    def _add_random_pedestrian(self) -> None:
        ls = self._ls
        for _ in range(ROUTE_TRIES if len(self._walk_edges) > 1 else 0):
            origin, destination = self._rng.sample(self._walk_edges, 2)
            depart_pos = self._rng.uniform(0.0, ls.lane.getLength(f"{origin}_0"))
            stages = ls.simulation.findIntermodalRoute(
                origin, destination, modes="", departPos=depart_pos, pType=npc_type_id("pedestrian")
            )
            if stages and all(s.edges for s in stages):
                pid = self._next_id("p")
                ls.person.add(pid, origin, depart_pos, depart=-3, typeID=npc_type_id("pedestrian"))
                for stage in stages:
                    ls.person.appendStage(pid, stage)
                return
        self.failed_routes += 1

    def _add_scripted_vehicle(self, v: ScriptedVehicle) -> None:
        ls = self._ls
        ls.route.add(f"r.{v.id}", v.edges)
        ls.vehicle.add(
            v.id,
            f"r.{v.id}",
            typeID=npc_type_id(v.kind),
            depart=f"{v.depart_s:g}",
            departLane="best",
            departPos=f"{v.depart_pos_m:g}",
            departSpeed=f"{v.depart_speed_mps:g}",
        )
        if v.stop is not None:
            lane = v.stop.lane if v.stop.lane is not None else _rightmost_car_lane(ls, v.stop.edge)
            ls.vehicle.setStop(v.id, v.stop.edge, v.stop.pos_m, lane, v.stop.duration_s)

    def _add_scripted_pedestrian(self, p: ScriptedPedestrian) -> None:
        ls = self._ls
        ls.person.add(
            p.id, p.edges[0], p.depart_pos_m, depart=p.depart_s, typeID=npc_type_id("pedestrian")
        )
        arrival = p.arrival_pos_m
        if arrival < 0:
            arrival += ls.lane.getLength(f"{p.edges[-1]}_0")
        ls.person.appendWalkingStage(p.id, p.edges, arrival)


def _edges_allowing(ls: Any, vclass: str) -> list[str]:
    """Normal (not internal) edges with at least one lane open to `vclass`, in id order."""
    edges = []
    for edge in ls.edge.getIDList():
        if edge.startswith(":"):
            continue
        lanes = ls.edge.getLaneNumber(edge)
        if any(_allows(ls, f"{edge}_{i}", vclass) for i in range(lanes)):
            edges.append(edge)
    return sorted(edges)


def _allows(ls: Any, lane: str, vclass: str) -> bool:
    allowed = ls.lane.getAllowed(lane)
    if allowed:
        return vclass in allowed
    return vclass not in ls.lane.getDisallowed(lane)


def _rightmost_car_lane(ls: Any, edge: str) -> int:
    for i in range(ls.edge.getLaneNumber(edge)):
        if _allows(ls, f"{edge}_{i}", "passenger"):
            return i
    return 0
