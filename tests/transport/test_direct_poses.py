"""Pose callbacks on Zenoh's network thread (`direct_pose_callbacks`): poses still arrive,
every one is checked, and a bad one is counted and dropped, never raised (real router,
authority and scripted node processes on 127.0.0.1; the observer in this process)."""

from __future__ import annotations

import threading
import time

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until


def _direct_observer(cluster: Cluster) -> NodeClient:
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    settings = NodeSettings(
        node_id="obs", session="t", kind="observer", actor_kind="", direct_pose_callbacks=True
    )
    client = NodeClient(session, settings, MonotonicClock()).start()
    cluster.sessions.append(client)
    return client


def _threads_handing_over(client: NodeClient) -> set[str]:
    """The names of the threads that hand poses to the world view, collected from now."""
    names: set[str] = set()
    push_wire = client.world.intake.pose

    def noted(node_id: str, payload: bytes, rx_t: float) -> None:
        names.add(threading.current_thread().name)
        push_wire(node_id, payload, rx_t)

    client.world.intake.pose = noted  # type: ignore[method-assign]
    return names


def test_direct_pose_callbacks_deliver_and_drop_bad_poses(cluster: Cluster) -> None:
    cluster.router()
    cluster.authority()
    cluster.scripted("a")
    obs = _direct_observer(cluster)
    threads = _threads_handing_over(obs)
    wait_until(lambda: obs.update() and "a" in obs.world.stats, 20, "a's poses")
    # zenoh-python's own callback thread is a Python thread named `...(pyo3-closure)`.
    assert threads and not any("pyo3-closure" in name for name in threads), threads
    outsider = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(outsider)
    nan_pose = bytearray(m.encode_pose(m.Pose(1, time.time(), 0, 0)))
    nan_pose[16:20] = b"\x00\x00\xc0\x7f"  # x = NaN
    bad = [b"", b"\x7f" * 64, bytes(nan_pose), m.encode_pose(m.Pose(1, 1.0, 0, 0))[:-1]]
    key = Keys("t").pose("a", "t0_0")

    def blast() -> bool:  # repeated: a fresh session's puts go nowhere until routes exist
        for payload in bad:
            outsider.put(key, payload)
        obs.update()  # a pose's bytes are checked when the world view drains them
        return obs.dropped["pose"] >= len(bad)

    wait_until(blast, 10, "the bad poses to be counted", poll=0.2)
    count = obs.world.stats["a"].count
    wait_until(lambda: obs.update() and obs.world.stats["a"].count > count + 10, 3, "a alive")
    assert obs.counters().handler_errors == {}  # none raised: each was counted as dropped
