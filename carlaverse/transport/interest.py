"""Interest management: a node hears the tiles around it, not the whole session.

The spatial keys end in the tile they are about (`ego/<id>/pose/<tile>`, `world/npc/<tile>`;
`carlaverse.keys`), so subscribing to a tile is asking the fabric to filter: the router (or,
between peers, the writer) sends a node nothing from tiles it did not subscribe to, and a
node's load follows the actors around it instead of the size of the session.

A node listens to the (2k+1)² tiles centred on its own tile. Both the node's own tile and
the tile in a publisher's key change with hysteresis (`TILE_HYSTERESIS_M` into the new tile),
so driving along a tile edge does not re-declare anything at every sample. Coverage: a sender
within `radius_m` of a node is always heard, because k is chosen so that k tiles reach
`radius_m` plus both hysteresis margins.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import zenoh

from carlaverse.keys import TILE_SIZE_M, Keys, tile_of, tile_token

TILE_HYSTERESIS_M = 25.0  # [m] how far into a new tile a point must be to count as in it

SampleHandler = Callable[[zenoh.Sample], None] | zenoh.handlers.Callback

# How every pose leaves, a node's and the swarm's: the next sample supersedes it, so under
# congestion it is dropped rather than queued, and it goes ahead of NPC batches and bulk.
# Not `express`: poses that meet on a link (a router's fan-out) then share frames, and a node
# hearing 256 egos pays a third to a half less CPU per pose; express would cut their delay
# instead (docs/benchmarks.md "Receive cost per pose, layer by layer" measures both).
POSE_QOS: dict[str, object] = {
    "congestion_control": zenoh.CongestionControl.DROP,
    "priority": zenoh.Priority.REAL_TIME,
}


class TileTracker:
    """The tile a moving point is in, changing only once the point is well inside a new one."""

    def __init__(self, hysteresis_m: float = TILE_HYSTERESIS_M) -> None:
        self.hysteresis_m = hysteresis_m
        self.tile: tuple[int, int] | None = None
        # The current tile grown by the hysteresis on every side, (x0, x1, y0, y1) [m]: the
        # point stays in the tile while inside it. Kept, not worked out on each update: every
        # pose a node publishes passes here, one check without a call.
        self.bounds = (math.inf, -math.inf, math.inf, -math.inf)

    def update(self, x: float, y: float) -> tuple[int, int]:
        """The current tile after moving to (x, y) [m]."""
        x0, x1, y0, y1 = self.bounds
        if x0 <= x < x1 and y0 <= y < y1:
            return self.tile  # type: ignore[return-value]  # (bounds are finite once it is set)
        tile = self.tile = tile_of(x, y)
        margin = self.hysteresis_m
        left, bottom = tile[0] * TILE_SIZE_M - margin, tile[1] * TILE_SIZE_M - margin
        span = TILE_SIZE_M + 2 * margin
        self.bounds = (left, left + span, bottom, bottom + span)
        return tile


def tile_reach(radius_m: float, hysteresis_m: float = TILE_HYSTERESIS_M) -> int:
    """k: how many tiles around its own a node listens to so that it hears `radius_m`."""
    return max(1, math.ceil((radius_m + 2 * hysteresis_m) / TILE_SIZE_M))


def tiles_around(tile: tuple[int, int], reach: int) -> frozenset[str]:
    """The tokens of the (2·reach+1)² tiles centred on `tile`."""
    ix, iy = tile
    span = range(-reach, reach + 1)
    return frozenset(tile_token(ix + dx, iy + dy) for dx in span for dy in span)


class TiledPublisher:
    """One node's pose publisher; its key follows the node from tile to tile. Its publishers
    have `POSE_QOS`, and `options` on top.

    `put` is called by one thread (the node's pose loop); a new tile declares a publisher
    on its key and undeclares the old one, a few times a minute for a car.
    """

    def __init__(self, session: zenoh.Session, keys: Keys, node_id: str, **options: object) -> None:
        self._session = session
        self._keys = keys
        self._node_id = node_id
        self._options: dict[str, Any] = {**POSE_QOS, **options}
        self._tracker = TileTracker()
        self._tile: tuple[int, int] | None = None
        self._publisher: zenoh.Publisher | None = None
        self.tile_changes = 0

    def put(self, payload: bytes, x: float, y: float) -> None:
        # The tracker's own first check, made here: a pose between its stamp and Zenoh's put
        # passes no Python call but this one while its node stays in its tile.
        x0, x1, y0, y1 = self._tracker.bounds
        if not (x0 <= x < x1 and y0 <= y < y1):
            tile = self._tracker.update(x, y)
            if tile != self._tile:
                self._switch(tile)
        self._publisher.put(payload)  # type: ignore[union-attr]

    def _switch(self, tile: tuple[int, int]) -> None:
        key = self._keys.pose(self._node_id, tile_token(*tile))
        publisher = self._session.declare_publisher(key, **self._options)
        if self._publisher is not None:
            self._publisher.undeclare()
            self.tile_changes += 1
        self._publisher, self._tile = publisher, tile

    def undeclare(self) -> None:
        if self._publisher is not None:
            self._publisher.undeclare()
            self._publisher = None
        self._tile = None


class InterestArea:
    """The tile subscriptions of one node, moved with it.

    `moved_to` is cheap and called with every own pose (from the pose thread); when the
    node's tile changes it returns True and `refresh`, called off that thread, declares the
    subscriptions of the tiles that came into reach and undeclares those that left it.
    Subscribers are per tile: a pose subscription (`ego/*/pose/<tile>`) and an NPC one
    (`world/npc/<tile>`), both delivered to the node's usual handlers.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        radius_m: float,
        on_pose: SampleHandler,
        on_npc: SampleHandler,
    ) -> None:
        self._session = session
        self._keys = keys
        self.radius_m = radius_m
        self.reach = tile_reach(radius_m)
        self._on_pose = on_pose
        self._on_npc = on_npc
        self._tracker = TileTracker()
        self._lock = threading.Lock()
        self._wanted: frozenset[str] = frozenset()
        self._declared: dict[str, tuple[object, object]] = {}
        self.refreshes = 0

    @property
    def tiles(self) -> frozenset[str]:
        """The tiles subscribed to now."""
        with self._lock:
            return frozenset(self._declared)

    def moved_to(self, x: float, y: float) -> bool:
        """The node is at (x, y) [m]; True if the area changed and `refresh` is due."""
        with self._lock:
            before = self._tracker.tile
            tile = self._tracker.update(x, y)
            if tile == before:
                return False
            self._wanted = tiles_around(tile, self.reach)
            return True

    def refresh(self) -> tuple[frozenset[str], frozenset[str]]:
        """Declare the tiles that came into reach, drop the ones that left: (added, dropped)."""
        with self._lock:
            wanted, declared = self._wanted, set(self._declared)
        added, dropped = wanted - declared, frozenset(declared - wanted)
        pose_sub, npc_sub = self._session.declare_subscriber, self._session.declare_subscriber
        fresh = {
            tile: (
                pose_sub(self._keys.poses_in(tile), self._on_pose,
                         allowed_origin=zenoh.Locality.REMOTE),
                npc_sub(self._keys.npc_in(tile), self._on_npc),
            )
            for tile in added
        }  # fmt: skip
        with self._lock:
            self._declared.update(fresh)
            gone = [self._declared.pop(tile) for tile in dropped]
        for subscribers in gone:
            for subscriber in subscribers:
                subscriber.undeclare()  # type: ignore[attr-defined]
        self.refreshes += 1
        return frozenset(added), dropped

    def close(self) -> None:
        with self._lock:
            gone, self._declared = list(self._declared.values()), {}
        for subscribers in gone:
            for subscriber in subscribers:
                subscriber.undeclare()  # type: ignore[attr-defined]
