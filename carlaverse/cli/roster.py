"""`carlaverse roster`: check a session roster and derive what each site needs from it.

carlaverse roster check session.yaml
carlaverse roster acl session.yaml --site tum            # the router's access_control
carlaverse roster passwords session.yaml --site tum      # create missing password files
carlaverse roster zenoh-config session.yaml --site tum   # full router config (zenohd)
carlaverse roster zenoh-config session.yaml --node tum-drive-1 --connect tls/host:7447
"""

from __future__ import annotations

import argparse
import json
import secrets
import sys
from pathlib import Path
from typing import Any

from carlaverse.cli.common import fail
from carlaverse.config import ConfigError
from carlaverse.redact import redact
from carlaverse.security.acl import site_acl
from carlaverse.security.certs import CertificateError
from carlaverse.security.roster import LoadedRoster, load_roster
from carlaverse.security.sites import node_fabric_settings, password_files, router_settings_for_site
from carlaverse.security.zenoh_entries import CredentialError, write_private
from carlaverse.transport.session import FabricSettings

PASSWORD_BYTES = 24  # 192 bits, base64url: 32 characters


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    check = sub.add_parser("check", help="validate the roster and list who joins from where")
    check.add_argument("roster")
    acl = sub.add_parser("acl", help="print a site router's Zenoh access_control config")
    acl.add_argument("roster")
    acl.add_argument("--site", required=True, help="the site whose router enforces it")
    acl.add_argument("--out", type=Path, help="write to this file instead of stdout")
    pw = sub.add_parser("passwords", help="create missing password files (usrpwd sessions)")
    pw.add_argument("roster")
    pw.add_argument("--site", help="only this site's nodes (and the routers')")
    cfg = sub.add_parser("zenoh-config", help="print a full Zenoh config for a router or node")
    cfg.add_argument("roster")
    who = cfg.add_mutually_exclusive_group(required=True)
    who.add_argument("--site", help="the router of this site")
    who.add_argument("--node", help="this node")
    cfg.add_argument("--connect", action="append", default=[], metavar="EP", help="node: router")
    cfg.add_argument("--out", type=Path, help="write to this file instead of stdout")


def run(args: argparse.Namespace) -> int:
    try:
        loaded = load_roster(args.roster)
        return ACTIONS[args.action](loaded, args)
    except (ConfigError, CertificateError, CredentialError) as exc:
        return fail("roster", str(exc))


def _check(loaded: LoadedRoster, args: argparse.Namespace) -> int:
    security = loaded.roster.security
    modes = [m for m, on in (("mtls", security.mtls), ("usrpwd", security.usrpwd)) if on]
    print(f"session {loaded.session}: {' + '.join(modes)}, certificates in {loaded.certs_dir}")
    for site in loaded.roster.sites:
        print(f"  site {site.name}: listen {' '.join(site.listen) or '-'}", end="")
        print(f", connect {' '.join(site.connect)}" if site.connect else "")
        for node in loaded.nodes_at(site.name):
            print(f"    {node.id} ({node.kind})")
    return 0


def _acl(loaded: LoadedRoster, args: argparse.Namespace) -> int:
    _emit({"access_control": site_acl(loaded, args.site)}, args.out)
    return 0


def _passwords(loaded: LoadedRoster, args: argparse.Namespace) -> int:
    if args.site:
        loaded.site(args.site)
    files = password_files(loaded, args.site)
    if not files:
        print("security.usrpwd is off: no passwords needed", file=sys.stderr)
    for path in files:
        if path.exists():
            tightened = _owner_only(path)
            print(f"kept    {path}{' (now 0600)' if tightened else ''}", file=sys.stderr)
        else:
            write_private(path, secrets.token_urlsafe(PASSWORD_BYTES) + "\n")
            print(f"created {path}")
    return 0


def _owner_only(path: Path) -> bool:
    """Make a kept password file 0600 if it was wider; True if it had to change."""
    if path.stat().st_mode & 0o077 == 0:
        return False
    path.chmod(0o600)
    return True


def _zenoh_config(loaded: LoadedRoster, args: argparse.Namespace) -> int:
    if args.site:
        settings = router_settings_for_site(loaded.source, args.site)
    else:
        settings = node_fabric_settings(loaded.source, args.node, args.connect)
    _emit(nested_config(settings), args.out)
    return 0


def nested_config(settings: FabricSettings) -> dict[str, Any]:
    """The settings as one nested Zenoh config object (what `zenohd -c` reads)."""
    from carlaverse.transport.session import build_config

    return json.loads(str(build_config(settings)))


def _emit(value: dict[str, Any], out: Path | None) -> None:
    """Print `value`, or write it to `out`: owner-only (0600) if it holds a secret (a login)."""
    text = json.dumps(value, indent=2) + "\n"
    if out is None:
        sys.stdout.write(text)
    elif redact(value) != value:
        write_private(out, text)
        print(f"wrote {out} (readable by you only: it holds a login)", file=sys.stderr)
    else:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
        print(f"wrote {out}", file=sys.stderr)


ACTIONS = {"check": _check, "acl": _acl, "passwords": _passwords, "zenoh-config": _zenoh_config}
