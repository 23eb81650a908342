"""Without a scenario, each embodied node that joins is given a start of its own.

Before, the authority without a scenario gave no spawn, so every drive, bike and walk node
started at the origin: a two-participant study found its driver and its rider in contact from
their first pose. Through the real join (Zenoh on loopback, the in-process authority every
membership-only test uses): a car and a bike get starts at least one car width plus a bike
width apart (4.5 m / 1.8 m and 1.8 m / 0.6 m boxes: side by side they touch below 1.2 m),
the first at the origin as before, a re-join keeps its start, and an observer gets none."""

from __future__ import annotations

import math

from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

TOUCHING_SIDE_BY_SIDE_M = (1.8 + 0.6) / 2  # half a car's width plus half a bike's


def _join(cluster: Cluster, node_id: str, kind: str, actor: str) -> NodeClient:
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    settings = NodeSettings(node_id=node_id, session="t", kind=kind, actor_kind=actor)
    client = NodeClient(session, settings, MonotonicClock()).start()
    cluster.sessions.append(client)
    wait_until(lambda: client.join_reply is not None, 30, f"{node_id}'s join")
    return client


def test_a_car_and_a_bike_start_apart_without_a_scenario(cluster: Cluster) -> None:
    cluster.router()
    cluster.in_process_authority().start()
    car = _join(cluster, "car", "drive", "car").join_reply
    bike = _join(cluster, "bike", "bike", "bicycle").join_reply
    watcher = _join(cluster, "obs", "observer", "").join_reply
    assert car is not None and bike is not None and watcher is not None
    assert car.spawn is not None and bike.spawn is not None
    assert (car.spawn.x, car.spawn.y) == (0.0, 0.0)  # the first where it always was
    apart = math.hypot(car.spawn.x - bike.spawn.x, car.spawn.y - bike.spawn.y)
    assert apart > 2 * TOUCHING_SIDE_BY_SIDE_M
    assert car.spawn.yaw == bike.spawn.yaw  # side by side, the same way: no one drives into one
    assert watcher.spawn is None
