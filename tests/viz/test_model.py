"""The viewer's inbox, model and feed: O(1) hand-over, bounded events, bad input counted, and
the world view written through its one door (`SampleFeed` into its intake)."""

from __future__ import annotations

import numpy as np

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.viz.model import ActorLook, WorldModel
from carlaverse.viz.raw import ActorFeed, RawTap
from carlaverse.viz.store import SampleStore
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.source import SampleFeed
from carlaverse.world.world_view import WorldView

KEYS = Keys("w")


def test_store_keeps_newest_state_and_every_event() -> None:
    store = SampleStore(events_max=3)
    for i in range(10):
        store.offer(
            KEYS.pose("a", "t0_0"), m.POSE.encode(m.Pose(i, i * 0.1, float(i), 0.0)), i * 0.1
        )
    for i in range(5):
        store.offer(KEYS.world("events"), m.WORLD_EVENT.encode(m.Spawned(i, 0.0, "a", "car")), 1.0)
    store.offer("carlaverse/w/unknown/key", b"x", 1.0)
    batch = store.take()
    assert len(batch.latest) == 1 and len(batch.events) == 3 and batch.dropped_events == 2
    assert sum(batch.counts.values()) == 15 and store.unknown_keys == 1
    assert not store.take().latest, "take() hands everything over once"


def _viewer() -> tuple[WorldView, SampleFeed]:
    view = WorldView("viewer", InterpolationSettings(render_mode="past"))
    return view, SampleFeed(view.intake)


def test_model_counts_bad_payloads_and_hands_membership_to_the_view() -> None:
    view, samples = _viewer()
    store, world = SampleStore(), WorldModel(samples, latency_of=lambda rx, t: rx - t)
    store.offer(KEYS.pose("a", "t0_0"), b"\x00garbage", 0.0)
    store.offer(KEYS.pose("b", "t0_0"), m.POSE.encode(m.Pose(1, 1.0, 3.0, 4.0, yaw=0.5)), 1.01)
    store.offer(KEYS.node("b"), b"", 1.0)  # b's presence token
    world.apply(store.take())
    assert world.bad["ego/a/pose/t0_0"] == 1
    assert abs(world.nodes["b"].latency_s - 0.01) < 1e-9
    assert world.newcomers, "an ego of unknown look: ask for a snapshot"
    view.update(1.02)
    assert view.present == {"b"}, "presence is the view's to know"
    ActorFeed(samples).offer(KEYS.pose("b", "t0_0"), m.encode_pose(m.Pose(2, 1.02, 3, 4)), 1.02)
    info = m.EgoInfo("b", "scripted", "truck", m.Extent(9.0, 2.5, 3.4), 9000.0)
    store.offer(KEYS.authority("snapshot"), m.SNAPSHOT.encode(m.Snapshot(1, 1.0, [info])), 1.03)
    store.offer(KEYS.world("events"), m.WORLD_EVENT.encode(m.Despawned(1, 1.04, "b", "left")), 1.05)
    world.apply(store.take())
    assert world.looks["b"] == ActorLook("truck", m.Extent(9.0, 2.5, 3.4))
    view.update(1.06)
    assert [(d.actor_id, d.reason) for d in view.despawns] == [("b", "left")]


def test_a_token_loss_before_the_authoritys_left_reads_left_in_a_viewer_as_in_a_node() -> None:
    """A leaver's token DELETE can reach a viewer before the authority's `left` event (two
    links); a node's view then amends the loss to `left`, and so must a viewer's: one set of
    reasons, whoever feeds the view. (The viewer once wrote its own strings, 'left (liveliness
    lost)' and 'despawned: left', which the amendment never matched.)"""
    view, samples = _viewer()
    store, world = SampleStore(), WorldModel(samples)
    store.offer(KEYS.node("b"), b"", 1.0)
    world.apply(store.take())
    ActorFeed(samples).offer(KEYS.pose("b", "t0_0"), m.encode_pose(m.Pose(1, 1.0, 3, 4)), 1.01)
    view.update(1.02)
    store.offer(KEYS.node("b"), b"", 1.03, "delete")
    world.apply(store.take())
    view.update(1.04)
    left = m.Despawned(1, 1.03, "b", "left")
    store.offer(KEYS.world("events"), m.WORLD_EVENT.encode(left), 1.05)
    world.apply(store.take())
    view.update(1.06)
    assert [(d.actor_id, d.reason) for d in view.despawns] == [("b", "left")]


def test_feed_drops_malformed_npc_batches_and_poses_and_taps_raw_samples() -> None:
    view, samples = _viewer()
    feed = ActorFeed(samples, RawTap())
    assert feed.raw is not None
    bad_npcs = m.NPC_BATCH.encode(m.NpcBatch(2, 1.1, ["n1"], b"\x01\x02"))  # rows for no one
    feed.offer(KEYS.world("npc"), bad_npcs, 1.1)
    feed.offer(KEYS.pose("b", "t0_0"), b"\x00garbage", 1.1)  # a pose is 64 bytes
    feed.offer("carlaverse/w/nowhere", b"", 1.1)
    assert view.dropped == {"npc": 1, "pose": 1, "key": 1}
    assert not view.intake.inbox and not feed.raw.npcs
    rows = np.zeros(2, dtype=m.NPC_DTYPE)
    feed.offer(
        KEYS.world("npc"), m.NPC_BATCH.encode(m.NpcBatch.pack(3, 1.2, ["n1", "n2"], rows)), 1.2
    )
    view.update(1.2)
    assert list(view.npcs) == ["n1", "n2"] and len(feed.raw.npcs) == 1


def test_invented_keys_and_node_ids_do_not_grow_the_viewer(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # Anyone in an open session may publish on keys and node ids of their own making.
    import tracemalloc

    from carlaverse.viz import model

    store = SampleStore()
    store.offer("carlaverse/w/unknown/warm-up", b"x", 0.0)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for i in range(5000):
            store.offer(f"carlaverse/w/unknown/{i}", b"x", 1.0)
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert store.unknown_keys == 5001 and grown < 50_000, grown  # a key each kept: ~1 MB
    monkeypatch.setattr(model, "COUNTED_LIMIT", 3)
    world = WorldModel()
    for i in range(5):
        store.offer(KEYS.pose(f"bad{i}", "t0_0"), b"\x00garbage", 1.0)
        store.offer(KEYS.pose(f"new{i}", "t0_0"), m.POSE.encode(m.Pose(1, 1.0, 0.0, 0.0)), 1.0)
    world.apply(store.take())
    assert list(world.nodes) == ["new0", "new1", "new2"]
    assert world.bad == {"ego/bad0/pose/t0_0": 1, "ego/bad1/pose/t0_0": 1,
                         "ego/bad2/pose/t0_0": 1, model.OTHERS: 4}  # fmt: skip
