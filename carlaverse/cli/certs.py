"""`carlaverse certs`: a test CA and certificates for a lab that has none.

    carlaverse certs --roster session.yaml            # CA + every router and node in the roster
    carlaverse certs --roster session.yaml --site tum # only the tum router and tum's nodes
    carlaverse certs --out certs --name tum --san-dns tum.example.org

The CA (`ca.pem`, `ca.key`) is created on first use and reused after; existing certificates
are kept unless `--force`. Keep `ca.key` with the session's organiser: whoever holds it can
issue identities.
"""

from __future__ import annotations

import argparse
import datetime as dt
import ipaddress
import sys
from pathlib import Path

from carlaverse.cli.common import fail
from carlaverse.config import ConfigError
from carlaverse.security.certs import (
    DEFAULT_VALID_DAYS,
    CertificateError,
    SubjectAltNames,
    ensure_authority,
    identity_files,
    issue_to_directory,
)
from carlaverse.security.roster import LoadedRoster, load_roster

DEFAULT_DNS = ("localhost",)
DEFAULT_IPS = ("127.0.0.1",)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--roster", help="session roster: issue for its routers and nodes")
    parser.add_argument("--site", help="with --roster: only this site's router and nodes")
    parser.add_argument("--out", type=Path, help="output directory (default: roster's certs_dir)")
    parser.add_argument(
        "--name",
        action="append",
        default=[],
        metavar="CN",
        help="issue a certificate with this common name (repeatable)",
    )
    parser.add_argument("--ca-name", default="carlaverse-test-ca", help="the CA's common name")
    parser.add_argument(
        "--san-dns", action="append", default=[], metavar="NAME", help="extra DNS name (SAN)"
    )
    parser.add_argument(
        "--san-ip", action="append", default=[], metavar="IP", help="extra IP address (SAN)"
    )
    parser.add_argument("--days", type=int, default=DEFAULT_VALID_DAYS, help="validity [days]")
    parser.add_argument("--force", action="store_true", help="re-issue existing certificates")


def _split_hosts(hosts: list[str]) -> SubjectAltNames:
    dns, ips = list(DEFAULT_DNS), list(DEFAULT_IPS)
    for host in hosts:
        try:
            ipaddress.ip_address(host)
        except ValueError:
            dns.append(host)
        else:
            ips.append(host)
    return SubjectAltNames(tuple(dict.fromkeys(dns)), tuple(dict.fromkeys(ips)))


def roster_targets(loaded: LoadedRoster, site: str | None) -> dict[str, list[str]]:
    """Common name -> the hostnames it is dialled by, for the roster's identities."""
    targets: dict[str, list[str]] = {}
    for spec in loaded.roster.sites:
        if site is None or spec.name == site:
            identity = loaded.site_identity(spec.name)
            targets[identity.common_name or spec.name] = list(spec.hostnames)
    for node in loaded.roster.nodes:
        if site is None or node.site == site:
            identity = loaded.node_identity(node.id)
            targets[identity.common_name or node.id] = []
    return targets


def run(args: argparse.Namespace) -> int:
    targets: dict[str, list[str]] = {}
    out = args.out
    try:
        if args.roster:
            loaded = load_roster(args.roster)
            if args.site:
                loaded.site(args.site)
            targets = roster_targets(loaded, args.site)
            out = out or loaded.certs_dir
        if out is None:
            return fail("certs", "say where: --out DIR, or --roster ROSTER")
        extra = [*args.san_dns, *args.san_ip]
        for name in args.name:
            targets.setdefault(name, [])
        now = dt.datetime.now(dt.UTC)
        authority, created = ensure_authority(out, args.ca_name, now, args.days)
        if created:
            print(f"created CA {out / 'ca.pem'} (keep {out / 'ca.key'} private)", file=sys.stderr)
        for name, hosts in targets.items():
            files = identity_files(out, name)
            if files.certificate.exists() and not args.force:
                print(f"kept    {files.certificate}", file=sys.stderr)
                continue
            sans = _split_hosts([*hosts, *extra])
            issue_to_directory(authority, out, name, sans, now, args.days)
            print(f"issued  {files.certificate} (SAN {', '.join(sans.dns + sans.ips)})")
    except (ConfigError, CertificateError, ValueError) as exc:
        return fail("certs", str(exc))
    return 0
