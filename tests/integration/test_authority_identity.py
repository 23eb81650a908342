"""Who speaks for the authority, and what a node does with it: real Zenoh sessions on loopback.

A router process, an in-process authority (restartable) and in-process nodes; an outsider's
session forges well-formed world messages and impulses.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import numpy as np
import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.authority.service import Authority
from carlaverse.keys import AUTHORITY_ID, Keys
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import JoinRefused, NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

KEYS = Keys("t")
TIMEOUT_S = 1.0  # despawn timeout of these authorities: short, so silence shows quickly


class Rig:
    """A router, a restartable in-process authority, nodes and an outsider, all on loopback."""

    def __init__(self, cluster: Cluster) -> None:
        self.cluster = cluster
        cluster.router()
        self._authority = cluster.in_process_authority(despawn_timeout_s=TIMEOUT_S)
        self.outsider = self.session()

    def session(self):  # type: ignore[no-untyped-def]
        session = open_session(FabricSettings(connect=[self.cluster.endpoint]))
        self.cluster.sessions.append(session)
        return session

    def start_authority(self) -> Authority:
        return self._authority.start()

    def stop_authority(self) -> None:
        self._authority.stop()

    def node(self, node_id: str, **settings: object) -> NodeClient:
        node = NodeSettings(node_id=node_id, session="t", **settings)  # type: ignore[arg-type]
        client = NodeClient(self.session(), node, MonotonicClock())
        self.cluster.sessions.append(client)
        return client

    def close(self) -> None:
        self._authority.stop()


@pytest.fixture
def rig(cluster: Cluster) -> Iterator[Rig]:
    r = Rig(cluster)
    try:
        yield r
    finally:
        r.close()


def impulse(contact_id: int, seq: int = 1) -> m.Impulse:
    return m.Impulse(seq, 0.0, contact_id, (1.0, 0, 0), (0, 0, 0), (1.0, 0, 0), "v1", "car", 3.0)


def test_world_messages_from_anyone_but_the_authority_are_rejected(rig: Rig) -> None:
    rig.start_authority()
    a = rig.node("a").start(pose_source=lambda t: m.Pose(0, t, 1.0, 2.0))
    b = rig.node("b", kind="observer", actor_kind="").start()
    assert a.wait_joined(10) and b.wait_joined(10)
    wait_until(lambda: b.update() and "a" in b.world.egos, 10, "b sees a")
    batch = m.NpcBatch.pack(1, 0.0, ["ghost-npc"], np.zeros(1, dtype=m.NPC_DTYPE))
    forged = {
        "events": [m.Spawned(1, 0.0, "authority", "drive"), m.Despawned(2, 0.0, "a", "left")],
        "npc": [batch],
        "lights": [m.LightsState(1, 0.0, [m.TrafficLight("J", "r", 0, 1.0)])],
        "weather": [m.Weather(1, 0.0, cloudiness=1.0)],
    }
    codecs = {"events": m.WORLD_EVENT, "npc": m.NPC_BATCH, "lights": m.LIGHTS, "weather": m.WEATHER}

    def forge() -> bool:
        for channel, messages in forged.items():
            for message in messages:
                rig.outsider.put(KEYS.world(channel), codecs[channel].encode(message))
        rig.outsider.put(KEYS.impulse("b"), m.IMPULSE.encode(impulse(7)))
        rejected = b.counters().rejected
        return all(rejected.get(f"{c}/not_from_authority") for c in (*forged, "impulse"))

    wait_until(forge, 10, "every forged channel rejected", poll=0.2)
    b.update()
    assert "a" in b.world.egos and "authority" not in b.world.egos
    assert not b.world.npcs and b.world.lights is None and b.world.weather is None
    assert not b.impulses and b.counters().impulses_accepted == 0
    assert b.counters().handler_errors == {}


def test_impulses_are_deduplicated_by_authority_and_contact_across_a_restart(rig: Rig) -> None:
    first = rig.start_authority()
    node = rig.node("drv", kind="observer", actor_kind="").start()
    assert node.wait_joined(10)
    first.outbox.impulse("drv", impulse(contact_id=1, seq=1))
    first.outbox.impulse("drv", impulse(contact_id=1, seq=2))  # the same contact again
    wait_until(lambda: node.counters().rejected.get("impulse/duplicate") == 1, 5, "the duplicate")
    assert node.counters().impulses_accepted == 1
    rig.stop_authority()
    wait_until(lambda: not node.joined.is_set(), 5, "the node to notice the authority left")
    second = rig.start_authority()
    wait_until(lambda: node.joined.is_set() and node.joins == 2, 10, "the re-join")
    # the new authority's counters restart: same seq, same contact id, yet a new impulse
    second.outbox.impulse("drv", impulse(contact_id=1, seq=1))
    wait_until(lambda: node.counters().impulses_accepted == 2, 5, "the new authority's impulse")
    assert [i.contact_id for i in node.impulses] == [1, 1]
    assert node.counters().rejected["impulse/duplicate"] == 1


def test_world_messages_between_two_authorities_are_early_not_forged(rig: Rig) -> None:
    """Once the joined authority's token goes, what comes before the next join cannot be
    checked against anyone: it is dropped and counted as early (`before_join`), not as
    forged; a new authority's first ticks would otherwise read as an attack."""
    rig.start_authority()
    node = rig.node("drv", kind="observer", actor_kind="").start()
    assert node.wait_joined(10)
    rig.stop_authority()
    wait_until(lambda: not node.joined.is_set(), 5, "the node to notice the authority left")
    weather = m.WEATHER.encode(m.Weather(1, 0.0, cloudiness=1.0))
    rig.outsider.put(KEYS.world("weather"), weather)
    wait_until(lambda: node.counters().before_join.get("weather"), 5, "the early weather")
    assert not [k for k in node.counters().rejected if k.endswith("/not_from_authority")]
    node.update()
    assert node.world.weather is None


def test_a_closing_authority_accepts_no_join_once_its_token_is_gone(rig: Rig) -> None:
    """A node asks to join again the moment it hears the authority's token go. Were the
    closing authority to accept it, the node would stay joined to no one (a full suite once
    saw it: a node that never noticed its authority had left)."""
    authority = rig.start_authority()
    request = m.JoinRequest(m.SCHEMA_VERSION, "late", "i1", "observer", actor_kind="")
    payload = m.JOIN_REQUEST.encode(request)
    accepted: list[bool] = []
    done = threading.Event()

    def on_reply(reply: zenoh.Reply) -> None:
        if reply.ok is not None:
            accepted.append(m.JOIN_REPLY.decode(reply.ok.payload.to_bytes()).accepted)

    def on_presence(sample: zenoh.Sample) -> None:
        # As a node does, but sooner: asked on Zenoh's network thread, the instant the
        # DELETE arrives (a callback handler: the query does not block this thread).
        if (
            str(sample.key_expr) == KEYS.node(AUTHORITY_ID)
            and sample.kind == zenoh.SampleKind.DELETE
        ):
            replies = zenoh.handlers.Callback(on_reply, drop=done.set, indirect=False)
            rig.outsider.get(KEYS.authority("join"), replies, payload=payload, timeout=2.0)

    presence = zenoh.handlers.Callback(on_presence, indirect=False)
    rig.outsider.liveliness().declare_subscriber(KEYS.all_nodes, presence)
    before = list(rig.outsider.get(KEYS.authority("join"), payload=payload, timeout=5.0))
    assert [m.JOIN_REPLY.decode(r.ok.payload.to_bytes()).accepted for r in before] == [True]
    authority.close()
    assert done.wait(5), "the join asked on the token's DELETE to finish"
    assert accepted == []


def test_a_node_despawned_for_silence_is_told_and_joins_again(rig: Rig) -> None:
    authority = rig.start_authority()
    mute = rig.node("mute").start()  # an actor that never publishes a pose
    assert mute.wait_joined(10)
    wait_until(lambda: ("mute", "timeout") in authority.despawned, 5, "the timeout despawn")
    wait_until(lambda: mute.joins >= 2, 5, "the told node to join again")


def test_a_join_without_a_token_is_despawned_for_silence(rig: Rig) -> None:
    authority = rig.start_authority()
    request = m.JoinRequest(m.SCHEMA_VERSION, "tokenless", "i1", "observer", actor_kind="")
    payload = m.JOIN_REQUEST.encode(request)
    # asked until answered: a fresh session learns of the queryable a moment after it is up
    replies = wait_until(
        lambda: list(rig.outsider.get(KEYS.authority("join"), payload=payload)), 10, "a reply"
    )
    assert m.JOIN_REPLY.decode(replies[0].ok.payload.to_bytes()).accepted
    wait_until(lambda: ("tokenless", "timeout") in authority.despawned, 5, "its despawn")
    assert "tokenless" not in authority.roster.tracks


def test_world_messages_carry_the_authority_session_id_and_only_it(rig: Rig) -> None:
    authority = rig.start_authority()
    node = rig.node("n", kind="observer", actor_kind="").start()
    assert node.wait_joined(10)
    assert node.join_reply is not None
    assert node.join_reply.authority_instance == str(authority.session.zid())
    authority.outbox.weather(m.Weather(1, 0.0, cloudiness=0.5))
    # the world view takes it in on its owner's update, as it takes everything
    wait_until(lambda: node.update() and node.world.weather, 5, "the authority's weather")
    assert node.counters().rejected == {}


def test_a_join_the_authority_cannot_read_is_refused_with_its_reason(rig: Rig) -> None:
    rig.start_authority()
    node = rig.node("nan-rate", pose_rate_hz=float("nan")).start()
    with pytest.raises(JoinRefused, match="pose_rate_hz"):
        node.wait_joined(10)
