"""`await_mesh`: a peer's first reliable put, made once the wait returns, reaches a peer that
subscribed long before (a real router in its own process, sessions on 127.0.0.1).

The defect this guards against: a router does not relay between its peers, so a put made
before the new peer has its direct link to the subscriber is lost. The demo's recording missed
the authority's first `world/lights` this way once in a suite run; without the wait a first put
right after open is lost about one time in two, so ten in a row all arriving is the test.
"""

from __future__ import annotations

import threading
import time

import zenoh

from carlaverse.transport.session import FabricSettings, await_mesh, open_session
from tests.support import Cluster, wait_until

ROUNDS = 10


def test_a_first_put_after_await_mesh_reaches_a_peer_subscribed_before(cluster: Cluster) -> None:
    cluster.router()
    listener = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(listener)
    heard: list[bytes] = []
    listener.declare_subscriber("mesh/**", lambda s: heard.append(s.payload.to_bytes()))
    stop = threading.Event()
    for k in range(ROUNDS):
        speaker = open_session(FabricSettings(connect=[cluster.endpoint]))
        try:
            assert await_mesh(speaker, stop, timeout_s=10.0)
            speaker.put(
                "mesh/first",
                f"first {k}".encode(),
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
            wait_until(lambda k=k: f"first {k}".encode() in heard, 5.0, f"first put of round {k}")
        finally:
            speaker.close()


def test_await_mesh_gives_up_when_nothing_answers_or_on_stop() -> None:
    lonely = open_session(FabricSettings(connect=[], listen=["tcp/127.0.0.1:0"]))
    try:
        began = time.monotonic()
        assert not await_mesh(lonely, threading.Event(), timeout_s=0.3)
        assert 0.3 <= time.monotonic() - began < 3.0
        stopped = threading.Event()
        stopped.set()
        assert not await_mesh(lonely, stopped, timeout_s=10.0)
    finally:
        lonely.close()
