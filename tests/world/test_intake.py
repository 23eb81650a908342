"""The world view's one door (`world/intake.py`) and the keyed samples routed through it
(`world/source.py`): one representation and one set of departure reasons, whoever writes."""

from __future__ import annotations

from typing import get_args

import numpy as np

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.world.intake import Departure
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.source import SampleFeed
from carlaverse.world.world_view import WorldView

KEYS = Keys("t")


def _view() -> tuple[WorldView, SampleFeed]:
    view = WorldView("me", InterpolationSettings())
    return view, SampleFeed(view.intake)


def test_every_reason_the_authority_gives_is_a_departure_and_far_is_the_views_own() -> None:
    # messages.DespawnReason is what the authority's `despawned` event may carry; a view
    # records those as they are, plus `far` for an actor out of its interest area.
    assert set(get_args(m.DespawnReason)) | {"far"} == set(get_args(Departure))


def test_a_pose_that_is_not_64_bytes_is_counted_at_the_door_and_our_own_never_enters() -> None:
    view, _ = _view()
    wire = m.encode_pose(m.Pose(1, 0.0, 0.0, 0.0))
    view.intake.pose("a", wire[:-1], 0.0)  # joined with others it would shift every row
    view.intake.pose("me", wire, 0.0)  # our own echo: not even queued
    view.intake.pose_rows(["a", "b"], wire, 0.0)  # two ids, one row
    assert view.dropped == {"pose": 3} and not view.intake.inbox


def test_keyed_samples_reach_the_view_as_a_live_node_would_apply_them() -> None:
    view, feed = _view()
    wire = m.encode_pose(m.Pose(1, 1.0, 5.0, 0.0))
    feed.route(KEYS.node("a"), "put", b"", 1.0)  # a's token appears
    feed.route(KEYS.pose("a", "t0_0"), "put", wire, 1.0)
    rows = np.zeros(1, dtype=m.NPC_DTYPE)
    batch = m.NPC_BATCH.encode(m.NpcBatch.pack(1, 1.0, ["n1"], rows))
    assert isinstance(feed.route(KEYS.world("npc"), "put", batch, 1.0), m.NpcBatch)
    # a tile's cut repeats the whole batch, a digest the poses on their own keys: not twice
    feed.route(KEYS.npc_in("t0_0"), "put", batch, 1.0)
    digest = m.POSE_DIGEST.encode(m.PoseDigest(1, ["a"], wire))
    feed.route(KEYS.pose_digest, "put", digest, 1.0)
    weather = m.Weather(1, 1.0, cloudiness=0.5)
    feed.route(KEYS.world("weather"), "put", m.WEATHER.encode(weather), 1.0)
    view.update(1.0)
    assert set(view.egos) == {"a"} and view.stats["a"].count == 1
    assert list(view.npcs) == ["n1"] and view.weather == weather
    left = m.WORLD_EVENT.encode(m.Despawned(2, 1.1, "a", "left"))
    feed.route(KEYS.world("events"), "put", left, 1.1)
    feed.route(KEYS.node("a"), "delete", b"", 1.2)  # its token goes after
    view.update(1.2)
    assert [(d.actor_id, d.reason) for d in view.despawns] == [("a", "left")]


def test_what_does_not_decode_is_counted_under_its_channel_and_skipped() -> None:
    view, feed = _view()
    assert feed.route(KEYS.world("weather"), "put", b"\xc1", 1.0) is None  # 0xc1: never used
    assert feed.route("carlaverse/t/nowhere/x", "put", b"", 1.0) is None
    feed.route(KEYS.node("a"), "put", b"", 1.0)
    feed.route(KEYS.pose("a", "t0_0"), "put", b"\x09" * 64, 1.0)  # an unknown layout version
    view.update(1.0)
    assert view.dropped == {"weather": 1, "key": 1, "pose": 1}
    assert view.weather is None and not view.egos
