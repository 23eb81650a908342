"""Ego keys declared to Zenoh as they are heard (`transport.key_routes`), on real Zenoh
sessions over 127.0.0.1: which keys get declared, when, how many, and that declaring a key
changes nothing a subscriber receives. (What it saves, Zenoh's matching of each sample
against its whole routing table, is CPU: `bench_peers --diagnose` measures it.)"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys, KeySpaceError
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.key_routes import KeyRoutes
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, linked_peers, wait_until

K = Keys("t")


@pytest.fixture
def pair() -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """Two peers linked over loopback: a listener (the receiver) and one connected to it."""
    with linked_peers() as (receiver, sender):
        yield receiver, sender


def test_a_key_heard_twice_is_declared_once_and_its_sender_kept(
    pair: tuple[zenoh.Session, zenoh.Session],
) -> None:
    routes = KeyRoutes()
    routes.attach(pair[0])
    key = K.pose("car-1", "t3_-2")
    try:
        assert routes.sender(key) == "car-1"  # heard once: not yet worth a declaration
        assert routes.senders == {}
        assert routes.sender(key) == "car-1"  # twice: a sender on this tile, declared
        assert routes.senders == {key: "car-1"}
        wait_until(lambda: routes.declared == [key], 5, "the key declared")
        for _ in range(5):  # heard again (a caller asks only for keys `senders` lacks)
            routes.sender(key)
        assert routes.declared == [key]
    finally:
        routes.close()
    assert routes.declared == []  # undeclared before the session closes


def test_keys_heard_once_each_declare_nothing(pair: tuple[zenoh.Session, zenoh.Session]) -> None:
    # A flood of made-up keys, each sent once: every one is parsed (its sender is named), none
    # is kept or declared, and what is remembered of them stays within the bound.
    routes = KeyRoutes(limit=8)
    routes.attach(pair[0])
    try:
        senders = [routes.sender(K.pose(f"n{i}", "t0_0")) for i in range(100)]
        assert senders == [f"n{i}" for i in range(100)]
        assert routes.senders == {}
        assert routes.declared == []
        assert len(routes._once) <= 8
    finally:
        routes.close()


def test_only_keys_of_its_ego_channels_are_accepted() -> None:
    routes = KeyRoutes()  # poses only, as the authority hears them
    for key in (K.ego("car-1", "state"), "carlaverse/t/ego/car 1/pose/t0_0", "elsewhere/pose"):
        with pytest.raises(KeySpaceError):
            routes.sender(key)
    assert routes.senders == {} and routes._once == {}
    # a node's: its wildcards bring poses, states and walkers' skeletons, never presence
    routes = KeyRoutes(channels=("pose", "state", "skeleton"))
    assert routes.sender(K.ego("walker-1", "skeleton")) == "walker-1"
    assert routes.sender(K.ego("car-1", "state")) == "car-1"
    with pytest.raises(KeySpaceError):
        routes.sender(K.node("car-1"))


def test_past_the_limit_the_oldest_declaration_goes(
    pair: tuple[zenoh.Session, zenoh.Session],
) -> None:
    # An ego crossing five tiles with room for three: its last three tiles stay declared; the
    # first two are forgotten, so heard again they would be noted and declared again.
    routes = KeyRoutes(limit=3)
    routes.attach(pair[0])
    keys = [K.pose("car-1", f"t{i}_0") for i in range(5)]
    try:
        for key in keys:
            routes.sender(key)
            routes.sender(key)
            wait_until(lambda key=key: key in routes.declared, 5, f"{key} declared")
        assert routes.declared == keys[2:]
        assert set(routes.senders) == set(keys[2:])
    finally:
        routes.close()


def test_a_declared_key_changes_nothing_a_wildcard_subscriber_receives(
    pair: tuple[zenoh.Session, zenoh.Session],
) -> None:
    # The receiver hears `ego/*/pose/**`; the sender puts 20 samples before the receiver
    # declares the key and 20 after. Each of the 40 arrives, once, in order.
    receiver, sender = pair
    got: list[bytes] = []
    arrived = threading.Condition()

    def on_sample(sample: zenoh.Sample) -> None:
        with arrived:
            got.append(sample.payload.to_bytes())
            arrived.notify_all()

    subscriber = receiver.declare_subscriber(K.all_ego("pose"), on_sample)
    key = K.pose("car-1", "t0_0")
    publisher = sender.declare_publisher(key)
    routes = KeyRoutes()
    routes.attach(receiver)
    try:
        # Zenoh links and propagates the subscription in the background: probe until a
        # sample gets through, then start counting.
        wait_until(lambda: publisher.put(b"probe") or b"probe" in got, 10, "the link up")
        with arrived:
            got.clear()
        for i in range(20):
            publisher.put(b"%d" % i)
        routes.sender(key)
        routes.sender(key)
        wait_until(lambda: routes.declared == [key], 5, "the key declared")
        for i in range(20, 40):
            publisher.put(b"%d" % i)
        wait_until(lambda: len([g for g in got if g != b"probe"]) >= 40, 10, "40 samples")
        assert [g for g in got if g != b"probe"] == [b"%d" % i for i in range(40)]
    finally:
        routes.close()
        publisher.undeclare()
        subscriber.undeclare()


def _pose(seq: int, t: float) -> m.Pose:
    return m.Pose(seq, t, 5.0, 2.0, 0.5, yaw=0.1, vx=1.5)


def test_a_node_and_the_authority_each_declare_the_key_a_pose_comes_on(tmp_path: Path) -> None:
    # One session as a site has it (a router, the authority, two nodes): a node publishing
    # its pose on its tile's key is heard by an observer (no actor, no interest area: it
    # hears the whole world) and by the authority, and both declare exactly that key; nobody
    # declares a key for the node's own poses.
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        authority = cluster.in_process_authority().start()
        hearer = cluster.observer("watch")
        session = open_session(FabricSettings(connect=[cluster.endpoint]))
        cluster.sessions.append(session)
        settings = NodeSettings(node_id="car-a", session="t", kind="scripted")
        sender = NodeClient(session, settings, MonotonicClock()).start()
        cluster.sessions.append(sender)
        assert sender.wait_joined(20) and hearer.wait_joined(20)
        # x = 5 m, y = 2 m lies in tile (0, 0) at any tile size above 5 m
        key = K.pose("car-a", "t0_0")

        def heard() -> bool:
            sender.publish_pose(_pose(1, sender.now()))
            hearer.update()
            return key in hearer.inbound.routes.declared and (
                key in authority._intake.routes.declared  # type: ignore[union-attr]
            )

        wait_until(heard, 20, "the pose key declared by the node and the authority")
        assert hearer.inbound.routes.declared == [key]
        assert sender.inbound.routes.declared == []  # its own poses never reach it
        assert "car-a" in hearer.world.egos
    finally:
        cluster.close()
