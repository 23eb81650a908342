"""Tiles, coverage and per-tile NPC batches without a network."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.authority.npc_tiles import split_by_tile
from carlaverse.keys import TILE_SIZE_M, Keys, KeySpaceError, parse, tile_of, tile_token
from carlaverse.transport.interest import (
    TILE_HYSTERESIS_M,
    TileTracker,
    tile_reach,
    tiles_around,
)
from carlaverse.world.interest_npcs import NpcTiles
from carlaverse.world.remote_actor import InterpolationSettings

K = Keys("s")
coordinate = st.floats(-20_000, 20_000, allow_nan=False)


def test_tiled_keys_parse_back_and_bad_tiles_are_refused() -> None:
    key = K.pose("car-1", "t3_-2")
    assert key == "carlaverse/s/ego/car-1/pose/t3_-2"
    parsed = parse(key)
    assert (parsed.node_id, parsed.channel, parsed.tile) == ("car-1", "pose", "t3_-2")
    assert K.with_session(key, "b") == Keys("b").pose("car-1", "t3_-2")
    assert parse(K.npc_in("t0_0")).tile == "t0_0" and parse(K.world("npc")).tile == ""
    for bad in ("3_2", "t3", "t*_2", "t3_2_1", "**"):
        with pytest.raises(KeySpaceError):
            K.pose("car-1", bad)
    with pytest.raises(KeySpaceError):
        parse("carlaverse/s/ego/car-1/pose/x")
    assert tile_token(*tile_of(10.0, -5.0)) == "t0_-1"


def _tiles_holding(x: float, y: float, margin_m: float) -> list[tuple[int, int]]:
    """Every tile a tracker may report for a point (it lags by up to the hysteresis)."""
    return [tile_of(x + dx, y + dy) for dx in (-margin_m, 0.0, margin_m)
            for dy in (-margin_m, 0.0, margin_m)]  # fmt: skip


@given(coordinate, coordinate, st.floats(0, 1), st.floats(0, 2 * math.pi),
       st.sampled_from([50.0, 200.0, 400.0]))  # fmt: skip
def test_a_sender_within_the_radius_is_always_in_a_subscribed_tile(
    x: float, y: float, fraction: float, bearing: float, radius_m: float
) -> None:
    distance = fraction * radius_m
    sx, sy = x + distance * math.cos(bearing), y + distance * math.sin(bearing)
    reach = tile_reach(radius_m)
    margin = TILE_HYSTERESIS_M * 0.999
    for mine in _tiles_holding(x, y, margin):
        heard = tiles_around(mine, reach)
        for theirs in _tiles_holding(sx, sy, margin):
            assert tile_token(*theirs) in heard


def test_the_tracker_keeps_its_tile_inside_the_hysteresis() -> None:
    tracker = TileTracker()
    assert tracker.update(TILE_SIZE_M - 1.0, 10.0) == (0, 0)
    assert tracker.update(TILE_SIZE_M + TILE_HYSTERESIS_M - 1.0, 10.0) == (0, 0)  # edge jitter
    assert tracker.update(TILE_SIZE_M + TILE_HYSTERESIS_M + 1.0, 10.0) == (1, 0)
    assert tracker.update(TILE_SIZE_M - 1.0, 10.0) == (1, 0)


def _batch(t: float, places: dict[str, tuple[float, float]]) -> m.NpcBatch:
    rows = np.zeros(len(places), dtype=m.NPC_DTYPE)
    if places:
        rows["x"], rows["y"] = zip(*places.values(), strict=True)
    return m.NpcBatch.pack(7, t, list(places), rows)


def test_a_batch_splits_by_tile_and_every_npc_lands_once() -> None:
    places = {f"n{i}": (float(i * 97 % 900 - 300), float(i * 61 % 700 - 200)) for i in range(60)}
    tiles = split_by_tile(_batch(1.0, places))
    assert sorted(i for b in tiles.values() for i in b.ids) == sorted(places)
    for tile, part in tiles.items():
        assert part.seq == 7 and part.t == 1.0
        for npc_id, row in zip(part.ids, part.array(), strict=True):
            assert tile_token(*tile_of(float(row["x"]), float(row["y"]))) == tile
            assert places[npc_id] == (row["x"], row["y"])
    assert split_by_tile(_batch(1.0, {})) == {}


def test_npc_tiles_draw_every_tile_together_and_forget_a_tile_left() -> None:
    view = NpcTiles(InterpolationSettings())
    for t in (1.0, 1.05):
        for tile, part in split_by_tile(_batch(t, {"a": (10.0, 10.0), "b": (600.0, 10.0)})).items():
            assert view.add(part, t + 0.01, tile)
    frame = view.frame(1.02, 0.5)
    assert frame is not None and sorted(frame.ids) == ["a", "b"] and len(frame.x) == 2
    view.keep_only(frozenset({"t0_0"}))
    assert list(view) == ["a"]


def test_the_remembered_parse_agrees_and_still_refuses() -> None:
    from carlaverse.keys import parse_cached

    key = K.pose("car-1", "t3_-2")
    assert parse_cached(key) == parse(key) and parse_cached(key) is parse_cached(key)
    for _ in range(2):  # a refused key is refused every time, never remembered as good
        with pytest.raises(KeySpaceError):
            parse_cached("carlaverse/s/ego/car-1/pose/x")
