"""Who may join a TLS site: certificates (mutual TLS) and user/password, with real routers."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterator
from pathlib import Path

import msgspec
import pytest
import zenoh

from carlaverse.keys import Keys
from carlaverse.security.certs import (
    SubjectAltNames,
    create_authority,
    issue_certificate,
    write_pair,
)
from carlaverse.security.sites import router_settings_for_site
from carlaverse.security.zenoh_entries import tls_entries, usrpwd_entries
from carlaverse.transport.session import FabricError, FabricSettings, open_session
from tests.security.lab import SESSION, Inbox, Lab
from tests.support import wait_until

K = Keys(SESSION)
NODES = [("authority", "authority", "a"), ("a-drive", "drive", "a"), ("b-bike", "bike", "b")]


@pytest.fixture
def lab(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[Lab]:
    mtls, usrpwd = request.param
    lab = Lab(tmp_path, NODES, mtls=mtls, usrpwd=usrpwd)
    lab.write()
    try:
        yield lab
    finally:
        lab.close()


def _exchange(sender: zenoh.Session, receiver: zenoh.Session) -> None:
    inbox = Inbox()
    receiver.declare_subscriber(K.pose("a-drive", "t0_0"), inbox)

    def arrived() -> bool:
        sender.put(K.pose("a-drive", "t0_0"), b"p")
        return bool(inbox.items)

    wait_until(arrived, 10, "a pose between two joined nodes", poll=0.1)


def _rogue_identity(tmp: Path, name: str) -> tuple[Path, Path, Path]:
    """A certificate with a legitimate common name, signed by a CA the session does not trust."""
    now = dt.datetime.now(dt.UTC)
    rogue = create_authority("rogue-ca", now)
    cert, key = issue_certificate(rogue, name, SubjectAltNames(), now)
    files = write_pair(cert, key, tmp / "rogue" / f"{name}.pem", tmp / "rogue" / f"{name}.key")
    write_pair(rogue.certificate, rogue.private_key, tmp / "rogue/ca.pem", tmp / "rogue/ca.key")
    return tmp / "rogue/ca.pem", files.certificate, files.private_key


# Refusals are checked with a short connect timeout; each test first shows that a legitimate
# node connects within that same timeout, so a refusal cannot be mere slowness.
SHORT = {"connect/timeout_ms": {"router": -1, "peer": 1000, "client": 1000}}


def _admitted(lab: Lab, settings: FabricSettings) -> None:
    lab.open(settings, **SHORT)


def _refused(lab: Lab, settings: FabricSettings, **entries: object) -> None:
    with pytest.raises(FabricError):
        lab.open(settings, **{**entries, **SHORT})


def _bare(lab: Lab, endpoint: str | None = None) -> FabricSettings:
    return FabricSettings(mode="client", connect=[endpoint or lab.endpoint("a")])


@pytest.mark.parametrize("lab", [(True, False)], indirect=True)
def test_mtls_site_admits_certified_nodes_only(lab: Lab, tmp_path: Path) -> None:
    lab.router("a")
    drive = lab.node("a-drive", "a")
    watcher = lab.node("authority", "a")
    _exchange(drive, watcher)
    _admitted(lab, lab.node_settings("a-drive", "a"))
    ca = lab.roster_path.parent / "certs" / "ca.pem"
    _refused(lab, _bare(lab), **tls_entries(ca, mtls=True))  # no client certificate
    rogue_ca, cert, key = _rogue_identity(tmp_path, "a-drive")
    _refused(lab, _bare(lab), **tls_entries(ca, cert, key, mtls=True))  # untrusted issuer
    _refused(lab, _bare(lab), **tls_entries(rogue_ca, cert, key, mtls=True))  # rogue world
    plain = lab.endpoint("a").replace("tls/", "tcp/")
    _refused(lab, _bare(lab, plain))  # not TLS at all


@pytest.mark.parametrize("lab", [(False, True), (True, True)], indirect=True)
def test_tls_and_auth_site_admits_logged_in_nodes_only(lab: Lab) -> None:
    lab.router("a")
    drive = lab.node("a-drive", "a")
    watcher = lab.node("authority", "a")
    _exchange(drive, watcher)
    good = lab.node_settings("a-drive", "a")
    _admitted(lab, good)
    _refused(lab, good, **usrpwd_entries("a-drive", "wrong-password"))
    _refused(lab, good, **usrpwd_entries("b-bike", "pw-a-drive"))  # someone else's name
    no_login = {k: v for k, v in good.zenoh.items() if "usrpwd" not in k}
    _refused(lab, msgspec.structs.replace(good, zenoh=no_login))


@pytest.mark.parametrize("lab", [(False, True)], indirect=True)
def test_usernames_carry_the_access_control(lab: Lab) -> None:
    """With usrpwd only, subjects are usernames: a logged-in node still cannot forge."""
    lab.router("a")
    lab.router("b")
    watcher = lab.node("authority", "a")
    bike = lab.node("b-bike", "b")
    inbox = Inbox()
    watcher.declare_subscriber(K.everything, inbox)

    def own_pose_arrived() -> bool:
        bike.put(K.pose("a-drive", "t0_0"), b"forged")
        bike.put(K.pose("b-bike", "t0_0"), b"own")
        return b"own" in inbox.payloads()

    wait_until(own_pose_arrived, 10, "the bike's own pose across sites", poll=0.1)
    assert b"forged" not in inbox.payloads()


@pytest.mark.parametrize("lab", [(True, False)], indirect=True)
def test_a_compromised_remote_router_cannot_speak_for_this_site(lab: Lab) -> None:
    """Site b's router lets everything through; site a's router still drops b's forgeries."""
    lab.router("a")
    open_router_b = router_settings_for_site(lab.roster_path, "b")
    lab.track(open_session(msgspec.structs.replace(open_router_b, zenoh={
        **open_router_b.zenoh, "access_control": {"enabled": False},
    })))  # fmt: skip
    watcher = lab.node("authority", "a")
    bike = lab.node("b-bike", "b")
    inbox = Inbox()
    watcher.declare_subscriber(K.everything, inbox)

    def own_pose_arrived() -> bool:
        bike.put(K.pose("a-drive", "t0_0"), b"forged")
        bike.put(K.world("npc"), b"forged")
        bike.put(K.pose("b-bike", "t0_0"), b"own")
        return b"own" in inbox.payloads()

    wait_until(own_pose_arrived, 10, "the bike's own pose across sites", poll=0.1)
    assert b"forged" not in inbox.payloads()


def test_quic_sites_enforce_the_same_identities_and_rules(tmp_path: Path) -> None:
    lab = Lab(tmp_path, NODES, scheme="quic")
    lab.write()
    try:
        lab.router("a")
        lab.router("b")
        watcher = lab.node("authority", "a")
        bike = lab.node("b-bike", "b")
        inbox = Inbox()
        watcher.declare_subscriber(K.everything, inbox)

        def own_pose_arrived() -> bool:
            bike.put(K.pose("a-drive", "t0_0"), b"forged")
            bike.put(K.pose("b-bike", "t0_0"), b"own")
            return b"own" in inbox.payloads()

        wait_until(own_pose_arrived, 10, "the bike's own pose across QUIC sites", poll=0.1)
        assert b"forged" not in inbox.payloads()
        _admitted(lab, lab.node_settings("a-drive", "a"))
        ca = lab.roster_path.parent / "certs" / "ca.pem"
        _refused(lab, _bare(lab), **tls_entries(ca, mtls=True))  # no certificate
    finally:
        lab.close()
