"""A clock query nobody answers in time is said plainly, once, at INFO (issue 43.8).

Under load an authority (or the link to it) leaves a clock query unanswered now and then; the
node asks again and keeps its last estimate of session time, so nothing is wrong that a user
must act on: no WARNING, one INFO sentence that says what is asked again, not one per query.
A real router and a real stand-in authority whose clock queryable holds every query unanswered
(each query then runs out its timeout, as under load), on 127.0.0.1.
"""

from __future__ import annotations

import logging

import pytest
import zenoh

from carlaverse.keys import Keys
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until

LOGGER = "carlaverse.transport.node_client"


def test_unanswered_clock_queries_are_one_plain_info_sentence(
    cluster: Cluster, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    cluster.router()
    silent = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(silent)
    held: list[zenoh.Query] = []  # a query dropped would end its get at once: keep them
    queryable = silent.declare_queryable(Keys("t43").authority("clock"), held.append)
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    node = NodeSettings(node_id="n1", session="t43", kind="observer", actor_kind="")
    client = NodeClient(session, node, MonotonicClock()).start()
    try:
        # Three queries held: the first two have run out their timeouts.
        wait_until(lambda: len(held) >= 3, 20.0, "three clock queries of the node")
    finally:
        client.close()
        held.clear()
        queryable.undeclare()
    ours = [r for r in caplog.records if r.name == LOGGER]
    assert not [r for r in ours if r.levelno >= logging.WARNING], [r.getMessage() for r in ours]
    said = [r for r in ours if "clock" in r.getMessage()]
    assert len(said) == 1, [r.getMessage() for r in said]  # once for the run, not per query
    text = said[0].getMessage()
    assert text.startswith("the authority of session 't43' did not answer a clock query"), text
    assert "asking again" in text and said[0].levelno == logging.INFO
