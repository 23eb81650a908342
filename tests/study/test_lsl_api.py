"""liblsl's configuration, chosen in one place and applied once per process."""

from __future__ import annotations

import configparser

import pytest

from carlaverse.study.lsl_api import LslConfigConflict, LslNetwork, config_text, load
from tests.study.lsl_support import NETWORK, lsl


def _ini(network: LslNetwork) -> configparser.ConfigParser:
    parser = configparser.ConfigParser()
    parser.optionxform = str  # type: ignore[assignment,method-assign]  # liblsl's keys are CamelCase
    parser.read_string(config_text(network))
    return parser


def test_machine_scope_keeps_discovery_on_this_host() -> None:
    # liblsl's lsl_api.cfg keys (docs: labstreaminglayer.readthedocs.io, info/lslapicfg):
    # [multicast] ResolveScope = machine, KnownPeers = {host, ...}, [ports] IPv6 = disable.
    ini = _ini(LslNetwork("machine", "s1", ("10.0.0.7",)))
    assert ini["multicast"]["ResolveScope"] == "machine"
    assert ini["multicast"]["KnownPeers"] == "{127.0.0.1, 10.0.0.7}"
    assert ini["ports"]["IPv6"] == "disable"
    assert ini["lab"]["SessionID"] == "s1"


def test_lab_scope_is_liblsl_default_site_scope() -> None:
    ini = _ini(LslNetwork("lab", "default"))
    assert ini["multicast"]["ResolveScope"] == "site"
    assert "KnownPeers" not in ini["multicast"] and "ports" not in ini


def test_a_second_configuration_in_one_process_is_refused() -> None:
    assert load(NETWORK) is lsl()  # the same one again is fine
    with pytest.raises(LslConfigConflict, match="reads its configuration once"):
        load(LslNetwork("lab", NETWORK.session_id))
