"""Which Zenoh mode a fabric command picks when `--mode` is not given."""

from __future__ import annotations

import argparse

import pytest

from carlaverse.cli.common import add_fabric_args, fabric_from_args
from carlaverse.transport.session import FabricSettings, on_this_host, reachable

# 192.0.2.0/24 is TEST-NET-1: never an address of this host. Nothing is sent to it: the test
# only binds (and fails to bind) a socket to learn that.
REMOTE = "tcp/192.0.2.1:7447"


def _settings(*argv: str, base: FabricSettings | None = None) -> FabricSettings:
    parser = argparse.ArgumentParser()
    add_fabric_args(parser)
    return fabric_from_args(parser.parse_args(list(argv)), base)


@pytest.mark.parametrize(
    ("endpoint", "here"),
    [
        ("tcp/127.0.0.1:7447", True),
        ("tcp/localhost:7447", True),
        ("tcp/0.0.0.0:7447", True),
        ("unixsock-stream//tmp/router.sock", True),
        (REMOTE, False),
        ("tcp/no-such-host.invalid:7447", False),
    ],
)
def test_on_this_host(endpoint: str, here: bool) -> None:
    assert on_this_host(endpoint) is here


def test_a_router_on_this_host_keeps_the_node_a_peer() -> None:
    assert _settings("--connect", "tcp/127.0.0.1:7447").mode == "peer"
    assert _settings().mode == "peer"  # nothing to connect to: peers find each other


def test_a_router_on_another_host_makes_the_node_a_client() -> None:
    assert _settings("--connect", REMOTE).mode == "client"
    assert _settings("--connect", "tcp/127.0.0.1:7447", "--connect", REMOTE).mode == "client"
    # from a config file's fabric section as well as from the flag
    assert _settings(base=FabricSettings(connect=[REMOTE])).mode == "client"


def test_an_explicit_mode_or_listen_is_kept() -> None:
    assert _settings("--connect", REMOTE, "--mode", "peer").mode == "peer"
    # who listens on an address the other hosts reach has made the peer reachable
    assert _settings("--connect", REMOTE, "--listen", "tcp/127.0.0.1:0").mode == "peer"


def test_library_callers_get_the_same_choice() -> None:
    # The launcher's presence watch opens its session through `reachable` too.
    assert reachable(FabricSettings(connect=[REMOTE])).mode == "client"
    assert reachable(FabricSettings(connect=["tcp/127.0.0.1:7447"])).mode == "peer"
    assert reachable(FabricSettings(mode="router", connect=[REMOTE])).mode == "router"
