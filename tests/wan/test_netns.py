"""Namespaced sites: isolated from each other, joined only through a relay in the core."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator

import pytest

from carlaverse.testing.linkemu import LinkEmulator, LinkProfile
from tests.wan.netns import (
    ECHO_CLIENT,
    ECHO_SERVER,
    NamespaceSet,
    NetNamespace,
    Veth,
    enter_netns,
    owned_namespaces,
    remove_orphans,
)

pytestmark = pytest.mark.netns


@pytest.fixture
def spaces() -> Iterator[NamespaceSet]:
    with owned_namespaces("t") as spaces:
        core, a, b = spaces.add("core"), spaces.add("a"), spaces.add("b")
        Veth(core, "to-a", "10.99.71.1", a, "wan0", "10.99.71.2").create()
        Veth(core, "to-b", "10.99.72.1", b, "wan0", "10.99.72.2").create()
        yield spaces


def _python(ns: NetNamespace, code: str) -> subprocess.Popen[str]:
    argv = ns.argv(sys.executable, "-c", code)
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_sites_talk_only_through_the_relay(spaces: NamespaceSet) -> None:
    core, a, b = (spaces.spaces[k] for k in ("core", "a", "b"))
    direct = _python(b, ECHO_CLIENT.format(addr="10.99.71.2", port=9000))
    assert direct.wait(timeout=10) != 0  # no route from site b to site a
    server = _python(a, ECHO_SERVER.format(addr="10.99.71.2"))
    assert server.stdout is not None and server.stdout.readline() == "listening\n"
    relay = LinkEmulator(
        ("10.99.72.1", 0),
        ("10.99.71.2", 9000),
        LinkProfile(0.005),
        thread_setup=lambda: enter_netns(core.name),
    ).start()
    try:
        client = _python(b, ECHO_CLIENT.format(addr="10.99.72.1", port=relay.port))
        out, err = client.communicate(timeout=10)
        assert out == "hello", err
        assert relay.counts["accepted"] == 1
    finally:
        relay.close()
        server.kill()
        server.wait()


def test_namespaces_are_removed_and_orphans_swept(spaces: NamespaceSet) -> None:
    orphan = NetNamespace("cvw999999-core").create()  # no such process: a killed run's
    assert "cvw999999-core" in remove_orphans()
    assert not orphan.created or not os.path.exists("/var/run/netns/cvw999999-core")
    names = [ns.name for ns in spaces.spaces.values()]
    assert all(os.path.exists(f"/var/run/netns/{n}") for n in names)  # ours are alive
    spaces.close()
    assert not any(os.path.exists(f"/var/run/netns/{n}") for n in names)
