"""A secured two-site session run exactly as the router README says: CLI processes only."""

from __future__ import annotations

from pathlib import Path

from tests.security.lab import SESSION, Lab
from tests.support import Cluster, wait_until

NODES = [("authority", "authority", "a"), ("a-drive", "drive", "a"), ("b-bike", "bike", "b")]


def _join(cluster: Cluster, lab: Lab, node_id: str, site: str, *extra: str) -> object:
    return cluster.start(
        "join", "scripted", "--id", node_id, "--session", SESSION, "--roster",
        str(lab.roster_path), "--connect", lab.endpoint(site), "--json", *extra, name=node_id,
    )  # fmt: skip


def test_nodes_join_a_tls_session_through_their_site_routers(
    cluster: Cluster, tmp_path: Path
) -> None:
    lab = Lab(tmp_path, NODES)
    lab.write()
    roster = str(lab.roster_path)
    routers = [cluster.start("router", "--site", s, "--config", roster, name=s) for s in "ab"]
    for router in routers:
        wait_until(lambda r=router: "listening" in r.output() or not r.alive(), 20, "router")
        assert router.alive(), router.output()
    authority = cluster.start(
        "authority", "--scenario", "none", "--session", SESSION, "--roster", roster,
        "--connect", lab.endpoint("a"), "--duration", "12", "--json", name="authority",
    )  # fmt: skip
    drive = _join(cluster, lab, "a-drive", "a", "--duration", "6")
    bike = _join(cluster, lab, "b-bike", "b", "--duration", "6")
    for node in (drive, bike):
        assert node.wait(timeout=40) == 0, node.output()
    seen = {name: node.json() for name, node in (("a-drive", drive), ("b-bike", bike))}
    assert seen["a-drive"]["joined"] and seen["b-bike"]["joined"]
    assert "b-bike" in seen["a-drive"]["actors_seen"]
    assert "a-drive" in seen["b-bike"]["actors_seen"]
    assert authority.alive()


def test_a_node_missing_from_the_roster_is_told_why(cluster: Cluster, tmp_path: Path) -> None:
    lab = Lab(tmp_path, NODES)
    lab.write()
    lab.ports["a"] = 1  # never dialled: the roster check fails first
    stranger = _join(cluster, lab, "stranger", "a", "--duration", "1")
    assert stranger.wait(timeout=30) == 2
    assert "no node 'stranger' in the roster" in stranger.output()
