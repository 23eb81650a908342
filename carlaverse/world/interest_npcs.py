"""NPCs arriving per tile: one `NpcTable` per tile stream, drawn together as one frame.

A node with an interest area receives the authority's NPC batches per tile
(`world/npc/<tile>`); an observer receives the whole world in one stream (`world/npc`,
kept under the tile ""). Each stream is interpolated on its own (its batches follow one
another in time), and `frame(t)` joins them. An NPC crossing a tile edge leaves one batch and
enters the next at the same instant, so it is drawn once; a tile that falls out of the area
is forgotten at once (`keep_only`), one that goes silent expires like any stream.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from carlaverse.messages import NpcBatch
from carlaverse.world.intake import WHOLE_WORLD
from carlaverse.world.npc_table import NpcFrame, NpcTable
from carlaverse.world.remote_actor import InterpolationSettings, StreamTiming


class NpcTiles:
    """The NPC streams of a node, by tile. Not thread-safe: one owner (the world view)."""

    def __init__(self, settings: InterpolationSettings) -> None:
        self.s = settings
        self._tables: dict[str, NpcTable] = {}

    def add(self, batch: NpcBatch, rx_t: float, tile: str = WHOLE_WORLD) -> bool:
        """Keep a batch of `tile` (False: malformed or older than that tile's newest)."""
        table = self._tables.get(tile)
        if table is None:
            table = self._tables[tile] = NpcTable(self.s)
        return table.add(batch, rx_t)

    @property
    def stale_batches(self) -> int:
        return sum(t.stale_batches for t in self._tables.values())

    @property
    def timing(self) -> StreamTiming:
        """The timing of the stream heard from last (all tiles come from one authority tick)."""
        if not self._tables:
            return StreamTiming(self.s)
        return max(self._tables.values(), key=lambda t: t.timing.last_rx_t).timing

    @property
    def ids(self) -> list[str]:
        return [npc_id for table in self._tables.values() for npc_id in table.ids]

    def __len__(self) -> int:
        return sum(len(t) for t in self._tables.values())

    def __contains__(self, npc_id: object) -> bool:
        return any(npc_id in t for t in self._tables.values())

    def __iter__(self) -> Iterator[str]:
        return iter(self.ids)

    def clear(self) -> None:
        self._tables.clear()

    def drop_expired(self, now: float) -> None:
        """Forget the streams silent for longer than the despawn timeout."""
        for tile in [k for k, t in self._tables.items() if t.is_expired(now)]:
            del self._tables[tile]

    def keep_only(self, tiles: frozenset[str]) -> None:
        """Forget every tile stream not in `tiles` (they left this node's interest area)."""
        for tile in [k for k in self._tables if k not in tiles]:
            del self._tables[tile]

    def is_expired(self, now: float) -> bool:
        return bool(self._tables) and all(t.is_expired(now) for t in self._tables.values())

    def is_stale(self, now: float) -> bool:
        return all(t.is_stale(now) for t in self._tables.values())

    def frame(self, t: float, max_extrapolation_s: float) -> NpcFrame | None:
        """Every NPC of every tile at session time `t`; None before the first batch."""
        frames = [f for f in (tb.frame(t, max_extrapolation_s) for tb in self._tables.values())
                  if f is not None]  # fmt: skip
        if len(frames) <= 1:
            return frames[0] if frames else None
        return NpcFrame(
            t, [npc_id for f in frames for npc_id in f.ids],
            *(np.concatenate([getattr(f, k) for f in frames])
              for k in ("x", "y", "z", "yaw", "vx", "vy", "extrapolated", "rows")),
        )  # fmt: skip
