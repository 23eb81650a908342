"""`NodeClient.close()` ends the node's threads promptly while its authority does not answer.

An authority that is shutting down (or wedged) still has its queryables declared but answers
nothing, so every clock query of a node waits out its timeout (0.5 s). Before it joins, a node
asks the clock in a burst of eight; if the burst ignored `close()`, the control thread lived on
for up to 4 s after it, past `close()`'s own 3 s wait for its threads, and a Ctrl-C'd demo
could overrun its grace period. A real router and a real queryable that holds every query
unanswered, on 127.0.0.1.
"""

from __future__ import annotations

import time

import zenoh

from carlaverse.keys import Keys
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

CLOCK_QUERY_TIMEOUT_S = 0.5  # NodeClient._sync_clock's


def test_close_ends_the_control_thread_within_one_query_while_the_authority_is_silent(
    cluster: Cluster,
) -> None:
    cluster.router()
    silent = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(silent)
    held: list[zenoh.Query] = []  # a query dropped would end its get at once: keep them
    queryable = silent.declare_queryable(Keys("t").authority("clock"), held.append)
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    node = NodeSettings(node_id="n1", session="t", kind="observer", actor_kind="")
    client = NodeClient(session, node, MonotonicClock()).start()
    try:
        wait_until(lambda: held, 20.0, "the node's first clock query")
    finally:
        started = time.monotonic()
        client.close()
        took = time.monotonic() - started
    alive = [t.name for t in client._threads if t.is_alive()]
    held.clear()
    queryable.undeclare()
    assert not alive, f"threads still running after close(): {alive}"
    # One query in flight may run out its timeout; the rest of the burst must not start.
    assert took < CLOCK_QUERY_TIMEOUT_S + 1.0, f"close() took {took:.2f} s"
