"""`fabric: {lowlatency: true}` in every process: nodes are admitted and every pair of peers
holds a link (a real router and authority, each in its own process, on 127.0.0.1).

The defect this guards against: Zenoh's low-latency transport holds one link per peer. Two
peers that learn of each other by gossip at the same moment (a node joining a running
session) dial each other at once, each keeps its own link and closes the other's, and the
pair is left without a transport; when the pair was the node and the authority, the node
was never admitted. Without the fix about one joining node in three lost a pair.
"""

from __future__ import annotations

import json
from pathlib import Path

from carlaverse.transport.node_client import NodeClient
from carlaverse.transport.session import LOWLATENCY_AUTOCONNECT, FabricSettings, build_config
from tests.support import Cluster, _accepts, wait_until

JOINERS = 6  # nodes joining one after another: 21 peer pairs dialled in all
ADMIT_S = 10.0  # [s] generous on a loaded 2-core host; a lost pair never recovers in it
MESH_S = 3.0  # [s] for every pair of peers to hold a link once a node was admitted


def test_lowlatency_config_lets_one_peer_of_a_pair_dial() -> None:
    config = build_config(FabricSettings(lowlatency=True))
    strategy = json.loads(config.get_json("scouting/gossip/autoconnect_strategy"))
    assert strategy == LOWLATENCY_AUTOCONNECT
    assert json.loads(config.get_json("transport/unicast/lowlatency")) is True


def test_lowlatency_nodes_are_admitted_and_every_pair_of_peers_links(cluster: Cluster) -> None:
    _lowlatency_router(cluster)
    cluster.authority("--lowlatency")
    nodes: list[NodeClient] = []
    for k in range(JOINERS):
        node = cluster.observer(f"ll{k}", lowlatency=True)
        assert node.wait_joined(ADMIT_S), f"ll{k} was not admitted within {ADMIT_S:g} s"
        nodes.append(node)
        _wait_for_full_mesh(nodes)


def _wait_for_full_mesh(nodes: list[NodeClient]) -> None:
    """Every node links with the authority and every other node, else fail naming the links."""
    others = len(nodes)  # for each node: the authority and the other nodes
    try:
        wait_until(lambda: all(_peers(n) == others for n in nodes), MESH_S, "a full mesh")
    except AssertionError:
        links = [_peers(n) for n in nodes]
        raise AssertionError(f"peers linked per node {links}, expected {others} each") from None


def _lowlatency_router(cluster: Cluster) -> None:
    config = Path(cluster.tmp) / "router.yaml"
    config.write_text("fabric:\n  mode: router\n  lowlatency: true\n")
    router = cluster.start("router", "--listen", cluster.endpoint, "--config", str(config))
    wait_until(lambda: _accepts(cluster.port) or not router.alive(), 30, "the router to listen")
    assert router.alive(), f"the router exited: {router.output()[-2000:]}"


def _peers(node: NodeClient) -> int:
    return len(list(node.session.info.peers_zid()))
