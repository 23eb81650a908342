"""Reading every NPC out of SUMO once per step, as columns, as cheaply as libsumo allows.

Per-object getters measured faster than subscriptions here (a subscription makes SUMO build
result maps for every object inside each step). What never changes for an NPC — its kind and
box, from its type — is looked up once per NPC and cached; the yaw rate is the heading change
since the previous step, vectorised whenever the id list is unchanged (most steps).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from carlaverse import messages as m
from carlaverse.traffic.engine import NpcFrame, kind_code
from carlaverse.traffic.sumo_demand import KIND_TYPES
from carlaverse.traffic.sumo_egos import EGO_PREFIX

# SUMO vehicle signal bits -> messages.LIGHT_* bits.
SIGNAL_BITS = (
    (1, m.LIGHT_RIGHT_BLINKER),
    (2, m.LIGHT_LEFT_BLINKER),
    (4, m.LIGHT_LEFT_BLINKER | m.LIGHT_RIGHT_BLINKER),  # hazard
    (8, m.LIGHT_BRAKE),
    (16, m.LIGHT_LOW_BEAM),
    (32, m.LIGHT_FOG),
    (64, m.LIGHT_HIGH_BEAM),
    (128, m.LIGHT_REVERSE),
)

Shape = tuple[int, float, float, float]  # kind code, length [m], width [m], height [m]


class NpcReader:
    """Turns SUMO's vehicles and persons (not the carried egos) into an `NpcFrame`."""

    def __init__(self, ls: Any, type_kinds: dict[str, str], step_length_s: float) -> None:
        self._ls = ls
        self._type_kinds = type_kinds  # SUMO type id -> actor kind
        self._step_s = step_length_s
        self._shapes: dict[str, Shape] = {}  # NPC id -> its shape, filled on first sight
        self._prev_ids: list[str] = []
        self._prev_yaw = np.zeros(0)
        self._get = _Getters(ls)
        self.vehicle_ids: set[str] = set()

    def read(self, t: float, carried: bool = True) -> NpcFrame:
        """All NPCs now; `carried` says whether egos are in SUMO and must be filtered out."""
        v, p = self._ls.vehicle, self._ls.person
        vids, pids = list(v.getIDList()), list(p.getIDList())
        if carried:
            vids = [i for i in vids if not i.startswith(EGO_PREFIX)]
            pids = [i for i in pids if not i.startswith(EGO_PREFIX)]
        ids = vids + pids
        self.vehicle_ids = set(vids)
        rows = np.zeros(len(ids), dtype=m.NPC_DTYPE)
        if not ids:
            self._prev_ids, self._prev_yaw = [], np.zeros(0)
            return NpcFrame(t, ids, rows)
        g = self._get
        pos = np.array([g.v_pos(i) for i in vids] + [g.p_pos(i) for i in pids])
        angle = np.array([g.v_angle(i) for i in vids] + [g.p_angle(i) for i in pids])
        speed = np.array([g.v_speed(i) for i in vids] + [g.p_speed(i) for i in pids])
        signals = np.array([g.v_signals(i) for i in vids] + [0] * len(pids), dtype=np.int64)
        shapes = np.array(self._shapes_of(vids, v) + self._shapes_of(pids, p))
        self._fill(rows, ids, pos, angle, speed, signals, shapes)
        return NpcFrame(t, ids, rows)

    def forget_gone(self) -> None:
        """Drop cached shapes of NPCs no longer present (called now and then, not per step)."""
        present = set(self._prev_ids)
        self._shapes = {i: s for i, s in self._shapes.items() if i in present}

    def _shapes_of(self, ids: list[str], domain: Any) -> list[Shape]:
        cache = self._shapes
        return [cache.get(i) or self._learn(i, domain) for i in ids]

    def _learn(self, npc_id: str, domain: Any) -> Shape:
        type_id = domain.getTypeID(npc_id)
        vt = self._ls.vehicletype
        kind = self._type_kinds.get(type_id) or _kind_of_vclass(vt.getVehicleClass(type_id))
        shape = (kind_code(kind), vt.getLength(type_id), vt.getWidth(type_id),
                 vt.getHeight(type_id))  # fmt: skip
        self._shapes[npc_id] = shape
        return shape

    def _fill(self, rows: np.ndarray, ids: list[str], pos: np.ndarray, angle: np.ndarray,
              speed: np.ndarray, signals: np.ndarray, shapes: np.ndarray) -> None:  # fmt: skip
        yaw = np.radians(90.0 - angle)
        cos, sin = np.cos(yaw), np.sin(yaw)
        half = shapes[:, 1] / 2.0
        # SUMO positions a vehicle by its front bumper; NPC rows carry the centre.
        rows["x"], rows["y"], rows["z"] = pos[:, 0] - half * cos, pos[:, 1] - half * sin, pos[:, 2]
        rows["yaw"] = yaw = np.arctan2(sin, cos)
        rows["vx"], rows["vy"] = speed * cos, speed * sin
        rows["yaw_rate"] = self._yaw_rates(ids, yaw)
        rows["kind"] = shapes[:, 0]
        rows["length"], rows["width"], rows["height"] = shapes[:, 1], shapes[:, 2], shapes[:, 3]
        rows["lights"] = _light_bits(signals)

    def _yaw_rates(self, ids: list[str], yaw: np.ndarray) -> np.ndarray:
        """[rad/s] heading change since the previous step; 0 for NPCs new this step."""
        if ids == self._prev_ids:
            previous = self._prev_yaw
        else:
            index = {i: k for k, i in enumerate(self._prev_ids)}
            at = np.fromiter((index.get(i, -1) for i in ids), dtype=np.intp, count=len(ids))
            previous = np.full(len(ids), math.nan)
            known = at >= 0
            previous[known] = self._prev_yaw[at[known]]
        rate = np.nan_to_num(np.remainder(yaw - previous + math.pi, math.tau) - math.pi)
        self._prev_ids, self._prev_yaw = ids, yaw
        return rate / self._step_s


class _Getters:
    """libsumo's per-object getters, called as directly as possible.

    The public functions (`libsumo.vehicle.getAngle`) are thin Python wrappers around the
    compiled ones in `libsumo._libsumo`; calling those directly saves a Python frame per
    call, about a quarter of the read at 700 NPCs. Falls back to the public API if a future
    libsumo renames them.
    """

    def __init__(self, ls: Any) -> None:
        raw = getattr(ls, "_libsumo", None)

        def pick(domain: str, name: str) -> Callable[[str], Any]:
            fast = getattr(raw, f"{domain}_{name}", None)
            return fast if callable(fast) else getattr(getattr(ls, domain), name)

        self.v_pos, self.p_pos = pick("vehicle", "getPosition3D"), pick("person", "getPosition3D")
        self.v_angle, self.p_angle = pick("vehicle", "getAngle"), pick("person", "getAngle")
        self.v_speed, self.p_speed = pick("vehicle", "getSpeed"), pick("person", "getSpeed")
        self.v_signals = pick("vehicle", "getSignals")


def _kind_of_vclass(vclass: str) -> str:
    for kind, spec in KIND_TYPES.items():
        if spec.vclass == vclass:
            return kind
    return "other"


def _light_bits(signals: np.ndarray) -> np.ndarray:
    out = np.zeros(signals.shape, dtype=np.uint16)
    for sumo_bit, our_bits in SIGNAL_BITS:
        out |= np.where(signals & sumo_bit, our_bits, 0).astype(np.uint16)
    return out
