"""Interest management over real Zenoh: a node hears the tiles around it and nothing else.

A router, an authority and two scripted nodes run as processes: `near` circles close to the
origin, `far` circles 5 km away. The node under test lives in this process with an actor of
its own at a position the test sets, and a 200 m interest radius.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import yaml

from carlaverse import messages as m
from carlaverse.keys import tile_of, tile_token
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, InProcessAuthority, wait_until

FAR_M = 5000.0  # [m] far beyond any interest radius
RESUBSCRIBE_BOUND_S = 2.0  # [s] a moved node hears its new neighbours within this


class Mover:
    """The pose of the node under test: wherever the test puts it."""

    def __init__(self) -> None:
        self.xy = (0.0, 0.0)
        self.moved_at = 0.0  # [s] monotonic time of the first pose at the new place
        self._moving = threading.Event()

    def move(self, x: float, y: float) -> None:
        self.xy = (x, y)
        self._moving.set()

    def pose(self, t: float) -> m.Pose:
        if self._moving.is_set():
            self._moving.clear()
            self.moved_at = time.monotonic()
        return m.Pose(0, t, *self.xy)


def circle(tmp: Path, name: str, cx: float, cy: float) -> Path:
    target = tmp / f"{name}.yaml"
    spec = {"type": "circle", "center": [cx, cy], "radius": 30.0, "speed_mps": 10.0}
    target.write_text(yaml.safe_dump({"path": spec}))
    return target


def node_under_test(cluster: Cluster, mover: Mover) -> NodeClient:
    session = open_session(
        FabricSettings(connect=[cluster.endpoint]), deadline=time.monotonic() + 20.0
    )
    cluster.sessions.append(session)
    node = NodeSettings(node_id="me", session="t", kind="scripted", interest_radius_m=200.0)
    client = NodeClient(session, node, MonotonicClock()).start(mover.pose)
    cluster.sessions.append(client)
    return client


def test_a_far_node_is_not_heard_until_we_move_near_it(cluster: Cluster) -> None:
    cluster.router()
    cluster.authority()
    cluster.scripted("near", circle(cluster.tmp, "near", 60.0, 40.0))
    cluster.scripted("far", circle(cluster.tmp, "far", FAR_M, FAR_M))
    obs = cluster.observer()  # the whole world: proves `far` is there and publishing
    mover = Mover()
    me = node_under_test(cluster, mover)
    wait_until(lambda: obs.update() and {"near", "far", "me"} <= set(obs.world.egos), 30, "all")
    wait_until(lambda: me.update() and "near" in me.world.egos, 10, "near heard by me")
    # Two seconds of `far` publishing at 50 Hz: the observer hears it, we hear none of it.
    far_seen = obs.world.stats["far"].count
    deadline = time.monotonic() + 2.0
    while time.monotonic() < deadline:
        me.update()
        obs.update()
        me._stop.wait(0.05)
    assert obs.world.stats["far"].count - far_seen > 50
    assert "far" not in me.world.egos and "far" not in me.world.stats
    assert tile_token(*tile_of(FAR_M, FAR_M)) not in me.interest.tiles

    mover.move(FAR_M + 50.0, FAR_M)
    heard_at = wait_until(
        lambda: me.update() and "far" in me.world.egos and time.monotonic(), 10, "far heard"
    )
    assert heard_at - mover.moved_at < RESUBSCRIBE_BOUND_S, heard_at - mover.moved_at
    # The old neighbour is out of earshot now: removed as `far`, not counted as a loss.
    wait_until(lambda: me.update() and "near" not in me.world.egos, 10, "near dropped")
    assert {d.actor_id: d.reason for d in me.world.despawns}["near"] == "far"


def npc_batch(seq: int, t: float, places: dict[str, tuple[float, float]]) -> m.NpcBatch:
    rows = np.zeros(len(places), dtype=m.NPC_DTYPE)
    rows["x"], rows["y"] = zip(*places.values(), strict=True)
    rows["vx"] = 5.0
    return m.NpcBatch.pack(seq, t, list(places), rows)


def test_npc_batches_reach_a_node_only_for_the_tiles_around_it(cluster: Cluster) -> None:
    cluster.router()
    authority = cluster.in_process_authority()
    cluster.sessions.append(_Stop(authority))
    out = authority.start().outbox
    obs = cluster.observer()
    me = node_under_test(cluster, Mover())
    wait_until(lambda: me.update() and me.interest.tiles, 20, "my interest area")
    places = {"npc-near": (40.0, -30.0), "npc-far": (FAR_M, 10.0)}

    def heard() -> bool:
        now = obs.clock.now()
        out.npc(npc_batch(out.next_seq(), now, places))
        me.update()
        obs.update()
        return "npc-near" in me.world.npcs and "npc-far" in obs.world.npcs

    wait_until(heard, 10, "the NPC batches")
    assert "npc-far" not in me.world.npcs  # its tile is 5 km away: never sent to us
    assert set(obs.world.npcs) == set(places)  # the whole world on `world/npc`
    # The near NPC drives away from us: its tile empties and we drop it at once.
    places = {"npc-near": (FAR_M, -30.0), "npc-far": (FAR_M, 10.0)}
    wait_until(lambda: heard() is not None and "npc-near" not in me.world.npcs, 10, "emptied")
    assert len(me.world.npcs) == 0


class _Stop:
    """Lets the cluster stop an in-process authority at teardown."""

    def __init__(self, authority: InProcessAuthority) -> None:
        self.authority = authority

    def close(self) -> None:
        self.authority.stop()
