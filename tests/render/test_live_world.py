"""The render process's world (`render.live.LiveWorld`) hears everyone else through its node
client — walkers' skeletons too — and never takes in its own node's pose, which it draws from
shared memory. A real router, an in-process authority and nodes, each on its own Zenoh
session, on 127.0.0.1."""

from __future__ import annotations

import threading

import numpy as np

from carlaverse import messages as m
from carlaverse.render.live import LiveWorld
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until


def _node(cluster: Cluster, node_id: str, actor_kind: str, x: float) -> NodeClient:
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    settings = NodeSettings(node_id=node_id, session="t", kind="scripted", actor_kind=actor_kind)
    client = NodeClient(session, settings, MonotonicClock())
    cluster.sessions.append(client)
    client.start(pose_source=lambda t: m.Pose(0, t, x, 0.0))
    assert client.wait_joined(20)
    return client


def _skeleton(live: LiveWorld, actor_id: str) -> dict[str, tuple[float, float, float]] | None:
    actor = live.frame().actor(actor_id)
    return None if actor is None else actor.skeleton


def test_the_view_hears_others_and_their_skeletons_and_never_its_own_node(
    cluster: Cluster,
) -> None:
    cluster.router()
    cluster.in_process_authority().start()
    _node(cluster, "d1", "car", 0.0)  # the node whose view this is
    walker = _node(cluster, "w1", "pedestrian", 12.0)
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    live = LiveWorld(session, NodeSettings(node_id="d1", session="t"), own=None)
    cluster.sessions.append(live)
    decoded: list[str] = []  # the senders of every pose the view's update decoded
    apply_rows = live.client.world._apply_rows

    def noted(ids: list[str], rows: list[bytes], rx: list[float]) -> None:
        decoded.extend(ids)
        apply_rows(ids, rows, rx)

    live.client.world._apply_rows = noted  # type: ignore[method-assign]
    live.start()
    knee = np.array([0.25, 0.0, 0.0], dtype="<f4").tobytes()  # (roll, pitch, yaw) [rad]
    stop = threading.Event()

    def walk() -> None:  # the walker's body source, as its node's step publishes it
        while not stop.wait(0.05):
            walker.publish_skeleton(m.Skeleton(0, walker.clock.local.now(), ["left_knee"], knee))

    body = threading.Thread(target=walk, daemon=True)
    body.start()
    try:
        drawn = wait_until(lambda: _skeleton(live, "w1"), 20, "the walker's body in the view")
    finally:
        stop.set()
        body.join(2)
    assert drawn["left_knee"] == (0.25, 0.0, 0.0)
    assert "w1" in decoded and "d1" not in decoded  # its own node's poses stop at the door
    assert "d1" not in live.client.world.egos and "d1" not in live.client.world.stats
    assert live.client.counters().handler_errors == {}
