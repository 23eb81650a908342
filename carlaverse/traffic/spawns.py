"""Ego spawn points: resolved against the network once, handed out per node kind.

A scenario names spawn points per node kind (`drive`, `bike`, `walk`, ...), either as world
coordinates or as a lane and a distance along it (which keeps working when a generated town
changes size). Joining nodes get the points of their kind in turn; a node that re-joins gets
its old point back. Kinds without points fall back to the `default` list.
"""

from __future__ import annotations

import math
import threading
from typing import Any

from carlaverse.messages import SpawnPoint
from carlaverse.traffic.scenario import Spawn

DEFAULT_KIND = "default"
# With more nodes of a kind than its points, the next round of nodes queues this far behind
# the round before it, along each point's heading: two nodes on one point would be in contact
# from their first pose (a study run found a driver and a rider colliding at the start).
QUEUE_GAP_M = 10.0


def resolve_spawn(net: Any, spawn: Spawn) -> SpawnPoint:
    """World pose of a spawn point; a lane that does not exist raises ValueError."""
    if spawn.lane is None:
        return SpawnPoint(float(spawn.x or 0.0), float(spawn.y or 0.0), spawn.z,
                          math.radians(spawn.yaw_deg))  # fmt: skip
    from sumolib import geomhelper

    try:
        lane = net.getLane(spawn.lane)
    except KeyError:
        raise ValueError(f"no lane {spawn.lane!r} in the network") from None
    shape = lane.getShape()
    offset = min(spawn.pos_m, lane.getLength())
    x, y = geomhelper.positionAtShapeOffset(shape, offset)
    yaw = geomhelper.rotationAtShapeOffset(shape, min(offset, lane.getLength() - 1e-3))
    return SpawnPoint(float(x), float(y), spawn.z, float(yaw or 0.0))


def resolve_spawns(net: Any, spawns: dict[str, list[Spawn]]) -> dict[str, list[SpawnPoint]]:
    out = {}
    for kind, points in spawns.items():
        resolved = []
        for index, spawn in enumerate(points):
            try:
                resolved.append(resolve_spawn(net, spawn))
            except ValueError as exc:
                raise ValueError(f"egos.{kind}[{index}]: {exc}") from exc
        out[kind] = resolved
    return out


def behind(point: SpawnPoint, rounds: int) -> SpawnPoint:
    """`point` moved `rounds` × QUEUE_GAP_M back along its heading."""
    back = rounds * QUEUE_GAP_M
    return SpawnPoint(point.x - back * math.cos(point.yaw), point.y - back * math.sin(point.yaw),
                      point.z, point.yaw)  # fmt: skip


class SpawnAllocator:
    """Hands out spawn points in turn per node kind (thread-safe: joins arrive on Zenoh threads)."""

    def __init__(self, points: dict[str, list[SpawnPoint]]) -> None:
        self._points = {k: v for k, v in points.items() if v}
        self._turn: dict[str, int] = {}
        self._given: dict[str, SpawnPoint] = {}
        self._lock = threading.Lock()

    def pick(self, node_kind: str, node_id: str) -> SpawnPoint | None:
        with self._lock:
            if node_id in self._given:
                return self._given[node_id]
            kind = node_kind if node_kind in self._points else DEFAULT_KIND
            points = self._points.get(kind)
            if not points:
                return None
            turn = self._turn.get(kind, 0)
            self._turn[kind] = turn + 1
            self._given[node_id] = behind(points[turn % len(points)], turn // len(points))
            return self._given[node_id]
