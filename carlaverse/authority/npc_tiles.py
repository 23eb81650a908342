"""The NPC batch cut by tile, for nodes that listen only to the tiles around them.

Beside the whole batch on `world/npc` (observers, recorders, viewers), the authority puts one
batch per tile on `world/npc/<tile>` (docs/architecture.md §3). A tile that had NPCs in the
previous batch and has none now gets one empty batch, so its listeners drop them at once
rather than after the despawn timeout. Zenoh sends a tile's batch only to whoever
subscribed to that tile.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import zenoh

from carlaverse import messages as m
from carlaverse.keys import TILE_SIZE_M, Keys, tile_token


def split_by_tile(batch: m.NpcBatch) -> dict[str, m.NpcBatch]:
    """One batch per tile that holds NPCs, with the whole batch's sequence number and time."""
    rows = batch.array()
    if len(rows) == 0:
        return {}
    ix = np.floor(rows["x"] / TILE_SIZE_M).astype(np.int64)
    iy = np.floor(rows["y"] / TILE_SIZE_M).astype(np.int64)
    # One integer per tile (a 1-D unique is several times faster than unique over rows).
    span = int(iy.max() - iy.min()) + 1
    code = (ix - ix.min()) * span + (iy - iy.min())
    codes, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(codes) + 1))
    cells = zip(ix[first].tolist(), iy[first].tolist(), strict=True)
    ids = batch.ids
    out = {}
    for k, (cx, cy) in enumerate(cells):
        members = order[bounds[k] : bounds[k + 1]]
        out[tile_token(cx, cy)] = m.NpcBatch.pack(
            batch.seq, batch.t, [ids[i] for i in members.tolist()], rows[members]
        )
    return out


class NpcTilePublisher:
    """Puts the per-tile batches, one declared publisher per tile ever used."""

    def __init__(
        self, session: zenoh.Session, keys: Keys, stamp: Callable[[], zenoh.Timestamp]
    ) -> None:
        self._session = session
        self._keys = keys
        self._stamp = stamp
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._occupied: set[str] = set()  # tiles that had NPCs in the last batch

    def put(self, batch: m.NpcBatch) -> int:
        """Send `batch` cut by tile; returns the number of tile batches sent."""
        tiles = split_by_tile(batch)
        for tile in self._occupied - tiles.keys():
            tiles[tile] = m.NpcBatch(batch.seq, batch.t, [], b"")
        self._occupied = {tile for tile, b in tiles.items() if b.ids}
        for tile, part in tiles.items():
            self._publisher(tile).put(m.NPC_BATCH.encode(part), timestamp=self._stamp())
        return len(tiles)

    def _publisher(self, tile: str) -> zenoh.Publisher:
        publisher = self._publishers.get(tile)
        if publisher is None:
            publisher = self._publishers[tile] = self._session.declare_publisher(
                self._keys.npc_in(tile), congestion_control=zenoh.CongestionControl.DROP
            )
        return publisher
