"""`carlaverse router`: host a site's Zenoh router from Python (no separate binary)."""

from __future__ import annotations

import argparse
import sys
import time

from carlaverse.cli.common import fail, stop_on_signals
from carlaverse.config import ConfigError, load_config
from carlaverse.config_check import RouterConfig
from carlaverse.transport.session import FabricError, FabricSettings, open_session

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Run a Zenoh router for one site. Nodes of the site connect to it; routers of other "
        "sites connect to each other. Listens on loopback unless told otherwise."
    )
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="EP",
        help=f"endpoint to listen on (repeatable; default {DEFAULT_LISTEN})",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="EP",
        help="another site's router to connect to (repeatable)",
    )
    parser.add_argument("--config", help="router YAML: a `fabric:` section (see router/)")
    parser.add_argument("--site", help="site name in a multi-site router config (see router/)")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")


def _settings(args: argparse.Namespace) -> FabricSettings:
    if args.config and args.site:
        from carlaverse.security.sites import router_settings_for_site

        base = router_settings_for_site(args.config, args.site)
    elif args.config:
        base = load_config(args.config, RouterConfig).fabric
    else:
        base = FabricSettings(mode="router", listen=[DEFAULT_LISTEN])
    listen = list(args.listen) or base.listen or [DEFAULT_LISTEN]
    connect = list(args.connect) or base.connect
    return FabricSettings(
        mode="router",
        listen=listen,
        connect=connect,
        lease_ms=base.lease_ms,
        keep_alive=base.keep_alive,
        lowlatency=base.lowlatency,
        zenoh=base.zenoh,
    )


def run(args: argparse.Namespace) -> int:
    try:
        settings = _settings(args)
        session = open_session(settings)
    except (ConfigError, FabricError) as exc:
        return fail("router", str(exc))
    stop = stop_on_signals()
    print(
        f"router {session.zid()} listening on {' '.join(settings.listen)}"
        + (f", connecting to {' '.join(settings.connect)}" if settings.connect else ""),
        flush=True,
    )
    started = time.monotonic()
    try:
        while not stop.is_set():
            if args.duration is not None and time.monotonic() - started >= args.duration:
                break
            stop.wait(0.2)
    finally:
        session.close()
    print("router stopped", file=sys.stderr)
    return 0
