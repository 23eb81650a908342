"""The session roster: who may join a multi-site session, from which site, as whom
(docs/architecture.md §12).

One YAML file, shared by every lab of the session (it holds no secrets, only names and file
references). Each site router derives its access control from it, and each node its TLS and
login settings:

    session: eu-demo
    security: {mtls: true, usrpwd: false, certs_dir: certs}
    sites:
      - name: tum
        listen: ["tls/0.0.0.0:7447"]
      - name: kth
        listen: ["tls/0.0.0.0:7447"]
        connect: ["tls/tum.example.org:7447"]
    nodes:
      - {id: authority, kind: authority, site: tum}
      - {id: tum-drive-1, kind: drive, site: tum}
      - {id: kth-bike-1, kind: bike, site: kth}

How identities are proven is a session-wide choice, because Zenoh negotiates it per link and
both ends must agree: with `mtls`, every node and router presents a certificate whose common
name is its id (or `credential.common_name`); with `usrpwd`, every node and router logs in
with a username (default: its id) and a password read from `credential.password_file`
(default `secrets/<id>.password`). Both may be on: then both must match.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import msgspec

from carlaverse.config import ConfigError, StrictStruct, load_config
from carlaverse.keys import AUTHORITY_ID, KeySpaceError, check_token

AUTHORITY_KIND = "authority"
# Kinds that only read the session: they may subscribe and query, never publish a pose.
READ_ONLY_KINDS = frozenset({"observer", "recorder", "viewer", "stats"})
# The study runner (issue 44): asks participants' nodes questionnaires on `study/<id>/...`
# and reads their answers; it publishes no pose.
STUDY_RUNNER_KIND = "study-runner"
DEFAULT_SITE_LISTEN = "tls/0.0.0.0:7447"


class RosterError(ConfigError):
    """The roster parses but contradicts itself (unknown site, duplicate identity, ...)."""


class Credential(StrictStruct):
    """How one node or site router proves who it is; unset fields take the defaults above."""

    common_name: str | None = None  # certificate subject CN (mtls); default: the id
    username: str | None = None  # login name (usrpwd); default: the id
    password_file: str | None = None  # relative to the roster; default secrets/<id>.password
    interfaces: list[str] = []  # optional: only accept this identity on these local NICs


class Site(StrictStruct):
    name: str
    listen: list[str] = msgspec.field(default_factory=lambda: [DEFAULT_SITE_LISTEN])
    connect: list[str] = []  # routers of other sites this site's router dials
    # Names and addresses others dial this router by: its certificate's subject alt names.
    hostnames: list[str] = []
    credential: Credential = Credential()
    # A WAN link must survive short outages: the lease is how long a silent link is kept.
    lease_ms: int = 5000
    keep_alive: int = 4


class RosterNode(StrictStruct):
    id: str
    kind: str
    site: str
    credential: Credential = Credential()


class Security(StrictStruct):
    mtls: bool = True
    usrpwd: bool = False
    certs_dir: str = "certs"  # relative to the roster: ca.pem, <name>.pem, <name>.key
    secrets_dir: str = "secrets"  # relative to the roster: <id>.password, dictionaries


class Roster(StrictStruct):
    session: str
    sites: list[Site]
    nodes: list[RosterNode]
    security: Security = Security()


@dataclass(frozen=True, slots=True)
class Identity:
    """A node's or router's credential with the session's defaults applied."""

    name: str  # node id or site name
    common_name: str | None
    username: str | None
    password_file: Path | None
    interfaces: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class LoadedRoster:
    """A validated roster and the directory its relative paths are resolved against."""

    roster: Roster
    directory: Path
    source: str

    @property
    def session(self) -> str:
        return self.roster.session

    @property
    def certs_dir(self) -> Path:
        return self.directory / self.roster.security.certs_dir

    @property
    def secrets_dir(self) -> Path:
        return self.directory / self.roster.security.secrets_dir

    def site(self, name: str) -> Site:
        for site in self.roster.sites:
            if site.name == name:
                return site
        known = ", ".join(s.name for s in self.roster.sites)
        raise RosterError(self.source, f"no site {name!r} in the roster (sites: {known})")

    def node(self, node_id: str) -> RosterNode:
        for node in self.roster.nodes:
            if node.id == node_id:
                return node
        known = ", ".join(n.id for n in self.roster.nodes)
        raise RosterError(self.source, f"no node {node_id!r} in the roster (nodes: {known})")

    def nodes_at(self, site: str) -> list[RosterNode]:
        return [n for n in self.roster.nodes if n.site == site]

    def authority(self) -> RosterNode:
        return next(n for n in self.roster.nodes if n.kind == AUTHORITY_KIND)

    def identity(self, name: str, credential: Credential, certified: bool = False) -> Identity:
        """`certified`: has a certificate even without mutual TLS (a router listening on TLS)."""
        security = self.roster.security
        password_file = None
        if security.usrpwd:
            password_file = self.directory / (
                credential.password_file or f"{security.secrets_dir}/{name}.password"
            )
        return Identity(
            name=name,
            common_name=(credential.common_name or name) if security.mtls or certified else None,
            username=(credential.username or name) if security.usrpwd else None,
            password_file=password_file,
            interfaces=tuple(credential.interfaces),
        )

    def node_identity(self, node_id: str) -> Identity:
        return self.identity(node_id, self.node(node_id).credential)

    def site_identity(self, site: str) -> Identity:
        return self.identity(site, self.site(site).credential, certified=True)


def load_roster(path: str | Path) -> LoadedRoster:
    """Load and validate a roster YAML; errors name the file and the offending entry."""
    resolved = Path(path).expanduser().resolve()
    roster = load_config(resolved, Roster)
    loaded = LoadedRoster(roster, resolved.parent, str(resolved))
    validate(loaded)
    return loaded


def validate(loaded: LoadedRoster) -> None:
    """Raise RosterError for the first inconsistency found."""
    roster, source = loaded.roster, loaded.source
    _check_names(roster, source)
    _check_sites(roster, source)
    _check_authority(roster, source)
    if not (roster.security.mtls or roster.security.usrpwd):
        raise RosterError(
            source,
            "security: neither mtls nor usrpwd is on, so routers cannot tell nodes apart "
            "and access control cannot work; set security.mtls: true (recommended)",
        )
    identities = [loaded.site_identity(s.name) for s in roster.sites]
    identities += [loaded.node_identity(n.id) for n in roster.nodes]
    _check_unique([i.common_name for i in identities if i.common_name], "common name", source)
    _check_unique([i.username for i in identities if i.username], "username", source)


def _check_names(roster: Roster, source: str) -> None:
    try:
        check_token(roster.session, "session name")
        for site in roster.sites:
            check_token(site.name, "site name")
        for node in roster.nodes:
            check_token(node.id)
            check_token(node.kind, "node kind")  # the kind decides the node's rights (acl.py)
    except KeySpaceError as exc:
        raise RosterError(source, str(exc)) from exc
    names = [s.name for s in roster.sites] + [n.id for n in roster.nodes]
    _check_unique(names, "site name / node id", source)


def _check_sites(roster: Roster, source: str) -> None:
    if not roster.sites:
        raise RosterError(source, "sites: at least one site is needed")
    sites = {s.name for s in roster.sites}
    for i, node in enumerate(roster.nodes):
        if node.site not in sites:
            raise RosterError(
                source,
                f"nodes[{i}] ({node.id}): unknown site {node.site!r}; "
                f"sites are {', '.join(sorted(sites))}",
            )


def _check_authority(roster: Roster, source: str) -> None:
    authorities = [n for n in roster.nodes if n.kind == AUTHORITY_KIND]
    if len(authorities) != 1:
        raise RosterError(
            source,
            f"nodes: exactly one node of kind 'authority' is needed, found {len(authorities)}",
        )
    if authorities[0].id != AUTHORITY_ID:
        raise RosterError(
            source,
            f"the authority's id must be {AUTHORITY_ID!r} (its keys use it), "
            f"not {authorities[0].id!r}; name its certificate with credential.common_name",
        )


def _check_unique(values: list[str], what: str, source: str) -> None:
    seen: set[str] = set()
    for value in values:
        if value in seen:
            raise RosterError(source, f"duplicate {what} {value!r}: each must be unique")
        seen.add(value)
