"""Fabric settings for a site router or a node of a secured session, from the roster.

    carlaverse router --site tum --config session.yaml      # router_settings_for_site
    node_fabric_settings("session.yaml", "tum-drive-1")     # a node's TLS and login

The router listens and dials as its site's identity, trusts the session CA, checks logins
against a dictionary built from the roster (written 0600 to `secrets/<site>.dictionary`) and
enforces the access control of `acl.site_acl`. Nodes are Zenoh `client`s by default in a
secured session: a client reaches everything through its router, so every message it sends
passes the router's rules. (Peers of one site would discover each other by gossip and talk
directly, past the router's rules.)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec

from carlaverse.config import ConfigError
from carlaverse.security.acl import site_acl
from carlaverse.security.certs import CertificateError, ca_file, identity_files
from carlaverse.security.roster import Identity, LoadedRoster, load_roster
from carlaverse.security.zenoh_entries import (
    CredentialError,
    acl_entries,
    dictionary_text,
    read_password,
    tls_entries,
    usrpwd_entries,
    write_private,
)
from carlaverse.transport.session import FabricSettings, Mode


def router_settings_for_site(config_path: str | Path, site: str) -> FabricSettings:
    """Everything `carlaverse router --site SITE --config ROSTER` needs to run that site.

    Raises ConfigError (naming the roster, the site and the missing file and how to make it).
    """
    loaded = load_roster(config_path)
    try:
        return _router_settings(loaded, site)
    except (CertificateError, CredentialError) as exc:
        raise ConfigError(f"{loaded.source} (site {site})", str(exc)) from exc


def _router_settings(loaded: LoadedRoster, site: str) -> FabricSettings:
    spec = loaded.site(site)
    identity = loaded.site_identity(site)
    entries: dict[str, Any] = dict(_tls(loaded, identity, listen=True))
    if loaded.roster.security.usrpwd:
        dictionary = write_dictionary(loaded, site)
        entries.update(_login(identity))
        entries.update(usrpwd_entries(dictionary_file=dictionary))
    entries.update(acl_entries(site_acl(loaded, site)))
    return FabricSettings(
        mode="router",
        listen=list(spec.listen),
        connect=list(spec.connect),
        lease_ms=spec.lease_ms,
        keep_alive=spec.keep_alive,
        zenoh=entries,
    )


def node_fabric_settings(
    config_path: str | Path,
    node_id: str,
    connect: list[str],
    mode: Mode = "client",
) -> FabricSettings:
    """A node's fabric settings: its certificate and/or login, dialing its site's router."""
    loaded = load_roster(config_path)
    identity = loaded.node_identity(node_id)
    try:
        entries = dict(_tls(loaded, identity, listen=False))
        if loaded.roster.security.usrpwd:
            entries.update(_login(identity))
    except (CertificateError, CredentialError) as exc:
        raise ConfigError(f"{loaded.source} (node {node_id})", str(exc)) from exc
    return FabricSettings(mode=mode, connect=list(connect), zenoh=entries)


def secure_fabric(
    base: FabricSettings, roster_path: str | Path, node_id: str | None, keep_mode: bool = False
) -> FabricSettings:
    """`base` plus the TLS and login entries of `node_id` (`--roster` of join and authority).

    The node becomes a `client` unless `keep_mode` (an explicit `--mode`): see the module doc.
    """
    if not node_id:
        raise ConfigError(str(roster_path), "--roster needs the node's id: pass --id NODE_ID")
    entries = node_fabric_settings(roster_path, node_id, connect=[]).zenoh
    mode = base.mode if keep_mode else "client"
    return msgspec.structs.replace(base, mode=mode, zenoh={**base.zenoh, **entries})


def write_dictionary(loaded: LoadedRoster, site: str) -> Path:
    """The login dictionary of `site`'s router: its own nodes and every other site's router."""
    logins = [_pair(loaded.node_identity(n.id)) for n in loaded.nodes_at(site)]
    logins += [_pair(loaded.site_identity(s.name)) for s in loaded.roster.sites if s.name != site]
    return write_private(loaded.secrets_dir / f"{site}.dictionary", dictionary_text(logins))


def password_files(loaded: LoadedRoster, site: str | None = None) -> list[Path]:
    """Password files a lab needs: its nodes' and every router's (routers log in to each other)."""
    if not loaded.roster.security.usrpwd:
        return []
    nodes = [n for n in loaded.roster.nodes if site is None or n.site == site]
    identities = [loaded.node_identity(n.id) for n in nodes]
    identities += [loaded.site_identity(s.name) for s in loaded.roster.sites]
    return [i.password_file for i in identities if i.password_file is not None]


def _pair(identity: Identity) -> tuple[str, str]:
    assert identity.username is not None and identity.password_file is not None
    return identity.username, read_password(identity.password_file)


def _login(identity: Identity) -> dict[str, Any]:
    user, password = _pair(identity)
    return usrpwd_entries(user, password)


def _tls(loaded: LoadedRoster, identity: Identity, listen: bool) -> dict[str, Any]:
    certs = loaded.certs_dir
    ca = ca_file(certs)
    if not ca.is_file():
        raise CertificateError(
            f"no session CA certificate at {ca}; get the session's ca.pem from its organiser "
            f"or create a test CA with: carlaverse certs --roster {loaded.source}"
        )
    # A router always needs a certificate to listen on tls/quic; a node only for mutual TLS.
    if not (listen or loaded.roster.security.mtls):
        return tls_entries(ca, mtls=False)
    files = identity_files(certs, identity.common_name or identity.name)
    for path in (files.certificate, files.private_key):
        if not path.is_file():
            raise CertificateError(
                f"missing {path} for {identity.name!r}; issue it with: "
                f"carlaverse certs --roster {loaded.source} --name {identity.name}"
            )
    return tls_entries(
        ca, files.certificate, files.private_key, mtls=loaded.roster.security.mtls, listen=listen
    )
