"""A throw-away multi-site lab for security tests: roster, real certificates, real routers."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec
import yaml
import zenoh

from carlaverse.security.certs import SubjectAltNames, ensure_authority, issue_to_directory
from carlaverse.security.roster import LoadedRoster, load_roster
from carlaverse.security.sites import node_fabric_settings, router_settings_for_site
from carlaverse.security.zenoh_entries import write_private
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import free_port

SESSION = "sec"

# Fail fast instead of retrying forever: a refused node must surface as an error here.
FAIL_FAST = {
    "connect/timeout_ms": {"router": -1, "peer": 3000, "client": 3000},
    "connect/exit_on_failure": {"router": False, "peer": True, "client": True},
}


@dataclass
class Lab:
    """Sites `a` and `b`; each node of `nodes` is (id, kind, site)."""

    root: Path
    nodes: list[tuple[str, str, str]]
    mtls: bool = True
    usrpwd: bool = False
    scheme: str = "tls"  # or "quic": same certificates, same rules
    ports: dict[str, int] = field(default_factory=dict)
    opened: list[Any] = field(default_factory=list)

    def write(self) -> LoadedRoster:
        self.ports = {"a": free_port(), "b": free_port()}
        roster = {
            "session": SESSION,
            "security": {"mtls": self.mtls, "usrpwd": self.usrpwd},
            "sites": [
                {"name": "a", "listen": [self.endpoint("a")]},
                {"name": "b", "listen": [self.endpoint("b")], "connect": [self.endpoint("a")]},
            ],
            "nodes": [{"id": i, "kind": k, "site": s} for i, k, s in self.nodes],
        }
        path = self.root / "session.yaml"
        path.write_text(yaml.safe_dump(roster), encoding="utf-8")
        loaded = load_roster(path)
        issue_all(loaded)
        if self.usrpwd:
            for name in ["a", "b", *(i for i, _, _ in self.nodes)]:
                write_private(loaded.secrets_dir / f"{name}.password", f"pw-{name}\n")
        return loaded

    @property
    def roster_path(self) -> Path:
        return self.root / "session.yaml"

    def endpoint(self, site: str) -> str:
        return f"{self.scheme}/localhost:{self.ports[site]}"

    def router(self, site: str) -> zenoh.Session:
        return self.track(open_session(router_settings_for_site(self.roster_path, site)))

    def node_settings(self, node_id: str, site: str) -> FabricSettings:
        return node_fabric_settings(self.roster_path, node_id, [self.endpoint(site)])

    def node(self, node_id: str, site: str, **zenoh_entries: Any) -> zenoh.Session:
        return self.open(self.node_settings(node_id, site), **zenoh_entries)

    def open(self, settings: FabricSettings, **zenoh_entries: Any) -> zenoh.Session:
        entries = {**settings.zenoh, **FAIL_FAST, **zenoh_entries}
        return self.track(open_session(msgspec.structs.replace(settings, zenoh=entries)))

    def track(self, session: zenoh.Session) -> zenoh.Session:
        self.opened.append(session)
        return session

    def close(self) -> None:
        for session in reversed(self.opened):
            session.close()
        self.opened.clear()


def issue_all(loaded: LoadedRoster) -> None:
    now = dt.datetime.now(dt.UTC)
    certs = loaded.certs_dir
    authority, _ = ensure_authority(certs, "test-ca", now)
    names = [s.name for s in loaded.roster.sites] + [n.id for n in loaded.roster.nodes]
    for name in names:
        issue_to_directory(authority, certs, name, SubjectAltNames(), now)


class Inbox:
    """Collects (key, payload) from a subscriber callback; thread-safe enough for list append."""

    def __init__(self) -> None:
        self.items: list[tuple[str, bytes]] = []

    def __call__(self, sample: zenoh.Sample) -> None:
        self.items.append((str(sample.key_expr), sample.payload.to_bytes()))

    def payloads(self, key: str | None = None) -> list[bytes]:
        return [p for k, p in self.items if key is None or k == key]

    def has(self, predicate: Callable[[str, bytes], bool]) -> bool:
        return any(predicate(k, p) for k, p in self.items)
