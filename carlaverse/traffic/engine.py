"""The traffic engine seam: what the authority's domain needs from a traffic simulator.

A `TrafficEngine` steps NPC vehicles and pedestrians on a road network, carries the humans as
externally controlled actors so NPCs react to them, runs the traffic-light programs, and
reports everything as columns (`NpcFrame`) so the collision matrix and the NPC batch never
touch one Python object per NPC.

Frame conventions follow `carlaverse.messages`: world frame of the road network (x east,
y north, metres), yaw counter-clockwise from +x in radians, positions at the actor's centre.
Engine time starts at 0 when the engine starts.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from carlaverse.dead_reckoning import npc_motion, project_many
from carlaverse.messages import ACTOR_KINDS, NPC_DTYPE
from carlaverse.traffic.scenario import ScriptedVehicle

KIND_CODE = {kind: code for code, kind in enumerate(ACTOR_KINDS)}


class EngineFailed(RuntimeError):
    """The traffic engine stopped working mid-session (its process died, failed or hung)."""


def kind_code(kind: str) -> int:
    """The NPC_DTYPE `kind` byte for an actor kind; unknown kinds count as 'other'."""
    return KIND_CODE.get(kind, KIND_CODE["other"])


@dataclass(frozen=True, slots=True)
class NpcFrame:
    """Every NPC at one engine instant: ids beside rows of `messages.NPC_DTYPE`."""

    t: float  # [s] engine time of the instant
    ids: list[str]
    rows: np.ndarray  # NPC_DTYPE, len(ids) rows, centre poses

    @classmethod
    def empty(cls, t: float = 0.0) -> NpcFrame:
        return cls(t, [], np.zeros(0, dtype=NPC_DTYPE))

    def __len__(self) -> int:
        return len(self.ids)

    def at(self, t: float) -> NpcFrame:
        """The frame dead-reckoned to engine time `t` by the one motion model
        (`carlaverse.dead_reckoning`: velocity turning at the yaw rate): the engine may step
        more coarsely than the authority ticks, so between its steps the collision matrix and
        the NPC batches see NPCs where they are now, not where the last step left them."""
        dt = t - self.t
        if dt == 0.0 or not self.ids:
            return self
        now = project_many(npc_motion(self.rows), dt)
        rows = self.rows.copy()
        rows["x"], rows["y"], rows["yaw"], rows["vx"], rows["vy"] = (
            now.x, now.y, now.yaw, now.vx, now.vy
        )  # fmt: skip
        return NpcFrame(t, self.ids, rows)


@dataclass(frozen=True, slots=True)
class EgoPlacement:
    """Where a human's actor is this step, for the engine to carry it (centre pose)."""

    node_id: str
    actor_kind: str  # one of messages.ACTOR_KINDS
    x: float  # [m]
    y: float  # [m]
    z: float  # [m]
    yaw: float  # [rad]
    speed: float  # [m/s] along the heading
    length: float  # [m]
    width: float  # [m]
    height: float  # [m]


PLACEMENT_COLUMNS = ("x", "y", "z", "yaw", "speed", "length", "width", "height")


@dataclass(frozen=True, slots=True)
class EgoPlacements(Sequence[EgoPlacement]):
    """The egos of one step as columns: `table[i]` holds ego i's `PLACEMENT_COLUMNS`.

    The authority builds these on the ticks that step and hands them to SUMO's process,
    which places the egos one at a time. Built as rows, 256 egos cost the tick that steps
    (its slowest) 1.0 ms to make and 0.6 ms to pickle and send; as columns 0.11 and 0.29 ms,
    and the rows are made in SUMO's process instead.
    """

    ids: list[str]
    actor_kinds: list[str]
    table: np.ndarray  # float64, shape (len(ids), len(PLACEMENT_COLUMNS))

    def __post_init__(self) -> None:
        shape = (len(self.ids), len(PLACEMENT_COLUMNS))
        if len(self.actor_kinds) != len(self.ids) or self.table.shape != shape:
            raise ValueError(
                f"placements: {len(self.ids)} ids, {len(self.actor_kinds)} kinds and a table "
                f"of shape {self.table.shape}, expected {shape}"
            )

    @classmethod
    def of(cls, egos: Sequence[EgoPlacement]) -> EgoPlacements:
        """Columns of a sequence of placements (or the columns themselves)."""
        if isinstance(egos, EgoPlacements):
            return egos
        rows = [[getattr(e, f) for f in PLACEMENT_COLUMNS] for e in egos]
        table = np.array(rows, dtype=np.float64).reshape(len(rows), len(PLACEMENT_COLUMNS))
        return cls([e.node_id for e in egos], [e.actor_kind for e in egos], table)

    def __len__(self) -> int:
        return len(self.ids)

    def __getitem__(self, i: int) -> EgoPlacement:  # type: ignore[override]
        if not -len(self.ids) <= i < len(self.ids):
            raise IndexError(f"placement {i} of {len(self.ids)}")
        return EgoPlacement(self.ids[i], self.actor_kinds[i], *self.table[i].tolist())

    def __iter__(self) -> Iterator[EgoPlacement]:
        rows = zip(self.ids, self.actor_kinds, self.table.tolist(), strict=True)
        return (EgoPlacement(node_id, kind, *values) for node_id, kind, values in rows)

    def __reduce__(self) -> tuple[type[EgoPlacements], tuple[object, ...]]:
        # Pickled for SUMO's process every step: the plain fields, not the dataclass's own
        # pickling, which looks up its fields on every call.
        return EgoPlacements, (self.ids, self.actor_kinds, self.table)


@dataclass(frozen=True, slots=True)
class LightPhase:
    duration_s: float  # [s]
    state: str  # one char per controlled link, SUMO style (r y g G o O s u)


@dataclass(frozen=True, slots=True)
class LightReading:
    """One traffic light now."""

    id: str
    state: str
    phase: int
    next_switch_s: float  # [s] engine time of the next phase switch


class TrafficEngine(Protocol):
    """A traffic simulator stepped by the authority (implemented by `SumoEngine`)."""

    @property
    def time_s(self) -> float:
        """[s] engine time of the last completed step."""
        ...

    @property
    def step_length_s(self) -> float: ...

    def step(self) -> None:
        """Advance one step of `step_length_s`."""
        ...

    @property
    def stepping(self) -> bool:
        """Whether the last step still runs elsewhere (another process): a step now would
        wait for it. Always False for an engine that steps in the caller's thread."""
        ...

    def npcs(self) -> NpcFrame:
        """All NPCs (not the egos) after the last step (read back now if not yet)."""
        ...

    def last_read(self) -> NpcFrame:
        """The NPCs as last read back, without reading: after a step not yet read, the
        frame of the step before (still good to dead-reckon from)."""
        ...

    def place_egos(self, egos: Sequence[EgoPlacement]) -> None:
        """Carry these egos this step; egos carried before but absent now are removed."""
        ...

    def stop_npc(self, npc_id: str) -> None:
        """Bring an NPC to an immediate standstill (it was hit)."""
        ...

    def remove_npc(self, npc_id: str) -> None: ...

    def light_readings(self) -> list[LightReading]: ...

    # Scenario triggers (ValueError naming what is wrong when an action cannot be done):

    def spawn_npc(self, vehicle: ScriptedVehicle) -> None:
        """Add a scripted vehicle that departs now."""
        ...

    def release_npc(self, npc_id: str) -> None:
        """Let a vehicle waiting at its stop drive on."""
        ...

    def command_speed(self, npc_id: str, speed_mps: float | None) -> None:
        """Drive a vehicle at exactly this speed, ignoring traffic rules (None: hand back)."""
        ...

    def set_light_state(self, light_id: str, state: str) -> None: ...

    def light_programs(self) -> dict[str, list[LightPhase]]:
        """The running program of every traffic light."""
        ...

    def set_light_program(
        self, light_id: str, phases: Sequence[LightPhase], offset_s: float
    ) -> None:
        """Replace a light's program (scenario overrides)."""
        ...

    def counters(self) -> dict[str, int]:
        """What the engine counted but could not do (routes, egos), for the authority's summary."""
        ...

    def close(self) -> None: ...
