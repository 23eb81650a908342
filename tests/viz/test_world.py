"""The viewer's inbox and model: O(1) hand-over, bounded events, bad input counted."""

from __future__ import annotations

import numpy as np

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.viz.store import SampleStore
from carlaverse.viz.world import WorldModel

KEYS = Keys("w")


def test_store_keeps_newest_state_and_every_event() -> None:
    store = SampleStore(events_max=3)
    for i in range(10):
        store.offer(KEYS.pose("a"), m.POSE.encode(m.Pose(i, i * 0.1, float(i), 0.0)), i * 0.1)
    for i in range(5):
        store.offer(KEYS.world("events"), m.WORLD_EVENT.encode(m.Spawned(i, 0.0, "a", "car")), 1.0)
    store.offer("carlaverse/w/unknown/key", b"x", 1.0)
    batch = store.take()
    assert len(batch.latest) == 1 and len(batch.events) == 3 and batch.dropped_events == 2
    assert sum(batch.counts.values()) == 15 and store.unknown_keys == 1
    assert not store.take().latest, "take() hands everything over once"


def test_model_counts_bad_payloads_and_tracks_actors() -> None:
    store, world = SampleStore(), WorldModel(latency_of=lambda rx, t: rx - t)
    store.offer(KEYS.pose("a"), b"\x00garbage", 0.0)
    store.offer(KEYS.pose("b"), m.POSE.encode(m.Pose(1, 1.0, 3.0, 4.0, yaw=0.5)), 1.01)
    rows = np.zeros(2, dtype=m.NPC_DTYPE)
    store.offer(
        KEYS.world("npc"), m.NPC_BATCH.encode(m.NpcBatch.pack(1, 1.0, ["n1", "n2"], rows)), 1.0
    )
    world.apply(store.take())
    assert world.bad["ego/a/pose"] == 1 and world.bad["world/npc"] == 0
    assert world.egos["b"].xyz == (3.0, 4.0, 0.0)
    assert abs(world.nodes["b"].latency_s - 0.01) < 1e-9
    assert set(world.npcs) == {"n1", "n2"}
    store.offer(KEYS.world("npc"), m.NPC_BATCH.encode(m.NpcBatch(2, 1.1, ["n1"], b"\x01\x02")), 1.1)
    world.apply(store.take())
    assert world.bad["world/npc"] == 1 and set(world.npcs) == {"n1", "n2"}, "bad batch ignored"
    store.offer(
        KEYS.world("npc"), m.NPC_BATCH.encode(m.NpcBatch.pack(3, 1.2, ["n1"], rows[:1])), 1.2
    )
    world.apply(store.take())
    assert set(world.npcs) == {"n1"} and ("n2", False, 1.2) in world.removed
    world.expire(now_rx=10.0, timeout_s=5.0)
    assert "b" not in world.egos, "a silent ego leaves the view"
