"""The traffic engine on Eclipse SUMO, in-process through libsumo.

libsumo is SUMO as a library: one simulation per process, driven by direct calls (about 25×
faster than TraCI over a socket). This class holds that one simulation; a second one in the
same process is refused rather than silently sharing libsumo's global state.

NPCs are read out by `sumo_reader`, demand is kept by `sumo_demand`, and the humans are
carried by `sumo_egos`; this class owns the simulation's lifetime, stepping and lights.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import msgspec

from carlaverse.traffic.engine import EgoPlacement, LightPhase, LightReading, NpcFrame
from carlaverse.traffic.scenario import ScriptedVehicle, Traffic
from carlaverse.traffic.sumo_demand import DemandKeeper, define_types
from carlaverse.traffic.sumo_egos import EgoCarrier
from carlaverse.traffic.sumo_reader import NpcReader
from carlaverse.traffic.sumo_tools import import_libsumo

log = logging.getLogger(__name__)

OVERRIDE_PROGRAM = "carlaverse"
SUMO_DEFAULT_SPEED_MODE = 31  # every check on (SUMO's default)
SPEED_MODE_COMMANDED = 32  # every check off, and disregard right of way inside junctions


class EngineBusyError(RuntimeError):
    """A second SUMO simulation was asked for in a process that already runs one."""


@dataclass(frozen=True, slots=True)
class SumoSettings:
    net: Path
    seed: int
    step_length_s: float  # [s]
    traffic: Traffic = field(default_factory=Traffic)


class SumoEngine:
    """A running SUMO simulation with NPC demand and carried egos (a `TrafficEngine`)."""

    _open: ClassVar[bool] = False

    def __init__(self, settings: SumoSettings) -> None:
        if SumoEngine._open:
            raise EngineBusyError(
                "a SUMO simulation is already running in this process; "
                "close it first (libsumo holds one per process)"
            )
        self._ls = import_libsumo()
        self._settings = settings
        self._ls.start(self._command(settings))
        SumoEngine._open = True
        self._closed = False
        self._egos = EgoCarrier(self._ls, settings.traffic.ego_match_radius_m)
        self._frame = NpcFrame.empty()
        self._unread = False  # a step whose NPCs are not read back yet
        # Lights change only when SUMO steps or we set them: read once between those.
        self._lights: list[LightReading] | None = None
        self._next_top_up = 0.0
        try:
            self._reader = NpcReader(self._ls, define_types(self._ls), settings.step_length_s)
            self._demand = DemandKeeper(
                self._ls, settings.traffic, settings.seed, settings.step_length_s
            )
            self._demand.add_scripted()
            self._top_up()
        except self._ls.TraCIException as exc:
            self.close()
            raise ValueError(f"traffic does not fit the network ({settings.net}): {exc}") from exc

    @staticmethod
    def _command(s: SumoSettings) -> list[str]:
        t = s.traffic
        cmd = ["sumo", "-n", str(s.net), "--step-length", f"{s.step_length_s:g}"]
        cmd += ["--seed", str(s.seed), "--begin", "0", "--no-step-log", "true"]
        cmd += ["--duration-log.disable", "true", "--ignore-route-errors", "true"]
        # Contacts are ours to judge (the collision matrix), never SUMO's to resolve.
        cmd += ["--collision.action", "none", "--time-to-teleport", f"{t.time_to_teleport_s:g}"]
        # Random NPCs that cannot enter a full town within a minute are dropped and replaced.
        cmd += ["--max-depart-delay", "60"]
        if t.action_step_s > 0:
            cmd += ["--default.action-step-length", f"{t.action_step_s:g}"]
        if not t.sumo_warnings:
            cmd += ["--no-warnings", "true"]
        return [*cmd, *t.sumo_options]

    # ------------------------------------------------------------------ stepping

    @property
    def time_s(self) -> float:
        return self._ls.simulation.getTime()

    @property
    def step_length_s(self) -> float:
        return self._settings.step_length_s

    @property
    def stepping(self) -> bool:
        return False  # each step is done when step() returns

    def step(self) -> None:
        if self._unread:  # each step read once: the yaw rates are per step
            self.npcs()
        self._ls.simulationStep()
        self._lights = None
        if self.time_s + 1e-9 >= self._next_top_up:
            self._top_up()
        # Read back when asked: a tick that steps can leave the read to the next tick.
        self._unread = True

    def _top_up(self) -> None:
        self._demand.top_up(self._egos.vehicles, self._egos.persons)
        self._reader.forget_gone()
        self._next_top_up = self.time_s + self._settings.traffic.top_up_interval_s

    def npcs(self) -> NpcFrame:
        if self._unread:
            self._frame = self._reader.read(self.time_s, carried=self._egos.carrying)
            self._unread = False
        return self._frame

    def last_read(self) -> NpcFrame:
        return self._frame

    # ------------------------------------------------------------------ egos and NPC reactions

    def place_egos(self, egos: Sequence[EgoPlacement]) -> None:
        self._egos.place(egos, self.time_s)

    @property
    def ego_failures(self) -> int:
        return self._egos.failures

    def counters(self) -> dict[str, int]:
        return {"failed_routes": self._demand.failed_routes, "ego_failures": self.ego_failures}

    def stop_npc(self, npc_id: str) -> None:
        ls = self._ls
        try:
            if npc_id in self._reader.vehicle_ids:
                ls.vehicle.setSpeedMode(npc_id, 0)
                ls.vehicle.setLaneChangeMode(npc_id, 0)
                ls.vehicle.setSpeed(npc_id, 0.0)
            else:
                ls.person.setSpeed(npc_id, 0.0)
        except ls.TraCIException as exc:
            log.debug("NPC %s to stop is gone: %s", npc_id, exc)

    def remove_npc(self, npc_id: str) -> None:
        ls = self._ls
        try:
            if npc_id in self._reader.vehicle_ids:
                ls.vehicle.remove(npc_id)
            else:
                ls.person.remove(npc_id)
        except ls.TraCIException as exc:
            log.debug("NPC %s to remove is gone: %s", npc_id, exc)

    # ------------------------------------------------------------------ scenario triggers

    def spawn_npc(self, vehicle: ScriptedVehicle) -> None:
        try:
            self._demand.add_now(msgspec.structs.replace(vehicle, depart_s=self.time_s))
        except self._ls.TraCIException as exc:
            raise ValueError(f"cannot spawn {vehicle.id} on {vehicle.edges}: {exc}") from exc

    def release_npc(self, npc_id: str) -> None:
        vehicle = self._ls.vehicle
        try:
            if vehicle.isStopped(npc_id):
                vehicle.resume(npc_id)
            elif vehicle.getStops(npc_id):  # still on its way to the stop: cancel it
                vehicle.replaceStop(npc_id, 0, "")
            else:
                raise ValueError(f"cannot release {npc_id}: it is not held at a stop")
        except self._ls.TraCIException as exc:
            raise ValueError(f"cannot release {npc_id}: {exc}") from exc

    def command_speed(self, npc_id: str, speed_mps: float | None) -> None:
        ls = self._ls
        try:
            if speed_mps is None:  # back to SUMO's own driving
                ls.vehicle.setSpeed(npc_id, -1)
                ls.vehicle.setSpeedMode(npc_id, SUMO_DEFAULT_SPEED_MODE)
                return
            # Exactly this speed next step: no safe-speed, acceleration, right-of-way or red
            # light checks (the caller limits acceleration), and no yielding inside junctions.
            ls.vehicle.setSpeedMode(npc_id, SPEED_MODE_COMMANDED)
            ls.vehicle.setLaneChangeMode(npc_id, 0)
            ls.vehicle.setSpeed(npc_id, speed_mps)
        except ls.TraCIException as exc:
            raise ValueError(f"cannot command {npc_id}: {exc}") from exc

    def set_light_state(self, light_id: str, state: str) -> None:
        tl = self._ls.trafficlight
        if light_id not in tl.getIDList():
            raise ValueError(f"no traffic light {light_id!r}; the network has {tl.getIDList()}")
        links = len(tl.getRedYellowGreenState(light_id))
        if len(state) != links:
            raise ValueError(
                f"light {light_id!r} controls {links} links, state {state!r} has {len(state)}"
            )
        tl.setRedYellowGreenState(light_id, state)
        self._lights = None

    # ------------------------------------------------------------------ traffic lights

    def light_readings(self) -> list[LightReading]:
        if self._lights is None:
            tl = self._ls.trafficlight
            self._lights = [
                LightReading(i, tl.getRedYellowGreenState(i), tl.getPhase(i), tl.getNextSwitch(i))
                for i in tl.getIDList()
            ]
        return self._lights

    def light_programs(self) -> dict[str, list[LightPhase]]:
        tl, programs = self._ls.trafficlight, {}
        for light_id in tl.getIDList():
            current = tl.getProgram(light_id)
            logic = next(lg for lg in tl.getAllProgramLogics(light_id) if lg.programID == current)
            programs[light_id] = [LightPhase(p.duration, p.state) for p in logic.phases]
        return programs

    def set_light_program(
        self, light_id: str, phases: Sequence[LightPhase], offset_s: float
    ) -> None:
        tl = self._ls.trafficlight
        known = tl.getIDList()
        if light_id not in known:
            raise ValueError(
                f"no traffic light {light_id!r} in the network; it has {sorted(known)}"
            )
        links = len(tl.getRedYellowGreenState(light_id))
        for phase in phases:
            if len(phase.state) != links:
                raise ValueError(
                    f"light {light_id!r} controls {links} links, but phase state "
                    f"{phase.state!r} has {len(phase.state)}"
                )
        sumo_phases = [self._ls.trafficlight.Phase(p.duration_s, p.state) for p in phases]
        tl.setProgramLogic(
            light_id, self._ls.trafficlight.Logic(OVERRIDE_PROGRAM, 0, 0, sumo_phases)
        )
        tl.setProgram(light_id, OVERRIDE_PROGRAM)
        self._apply_offset(light_id, phases, offset_s)
        self._lights = None

    def _apply_offset(self, light_id: str, phases: Sequence[LightPhase], offset_s: float) -> None:
        """Start the cycle as SUMO's `offset` would: at time 0 it is (-offset) into the cycle."""
        cycle = sum(p.duration_s for p in phases)
        into = (self.time_s - offset_s) % cycle
        for index, phase in enumerate(phases):
            if into < phase.duration_s:
                self._ls.trafficlight.setPhase(light_id, index)
                self._ls.trafficlight.setPhaseDuration(light_id, phase.duration_s - into)
                return
            into -= phase.duration_s

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self._egos.clear()
        finally:
            self._ls.close()
            SumoEngine._open = False
