"""`carlaverse join KIND`: join a session as a node of the given kind."""

from __future__ import annotations

import argparse
import sys

import msgspec

from carlaverse.cli.common import (
    add_fabric_args,
    add_output_args,
    fabric_from_args,
    fail,
    print_json,
    stop_on_signals,
)
from carlaverse.config import ConfigError, load_config
from carlaverse.fabric.node_client import JoinRefused
from carlaverse.fabric.session import FabricError
from carlaverse.keys import KeySpaceError, check_token
from carlaverse.node_runtime import UnknownNodeKind, load_node_kind, node_kinds, run_node


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Join a session as a node. Kinds are plug-ins (entry-point group carlaverse.nodes); "
        f"installed: {', '.join(sorted(node_kinds()))}."
    )
    parser.add_argument("kind", help="node kind, e.g. observer, scripted, drive")
    parser.add_argument(
        "--id", dest="node_id", help="node id, unique in the session (e.g. tum-drive-1)"
    )
    parser.add_argument("--config", help="node YAML (path, or name of a shipped config)")
    parser.add_argument(
        "--backend",
        help="force every device of the node onto this backend (e.g. sim: run headless "
        "with a scripted driver/rider, no hardware)",
    )
    parser.add_argument(
        "--join-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="how long to wait for the authority before running unjoined",
    )
    add_fabric_args(parser)
    add_output_args(parser)


def run(args: argparse.Namespace) -> int:
    try:
        kind_cls = load_node_kind(args.kind)
        config = (
            load_config(args.config, kind_cls.config_type)
            if args.config
            else kind_cls.config_type()
        )
    except (UnknownNodeKind, ConfigError) as exc:
        return fail("join", str(exc))
    node_settings = config.node
    if args.node_id:
        node_settings = msgspec.structs.replace(node_settings, node_id=args.node_id)
    if args.session:
        node_settings = msgspec.structs.replace(node_settings, session=args.session)
    if not node_settings.node_id:
        return fail("join", "no node id: pass --id NODE_ID or set node.node_id in the config")
    try:
        check_token(node_settings.node_id)
        check_token(node_settings.session, "session name")
    except KeySpaceError as exc:
        return fail("join", str(exc))
    config = msgspec.structs.replace(config, node=node_settings)
    try:
        fabric = fabric_from_args(args, config.fabric, identity=node_settings.node_id)
    except ConfigError as exc:
        return fail("join", str(exc))
    config = msgspec.structs.replace(config, fabric=fabric)
    stop = stop_on_signals()
    try:
        if args.backend:
            if not hasattr(kind_cls, "with_backend"):
                return fail("join", f"node kind {args.kind!r} has no devices for --backend")
            config = kind_cls.with_backend(config, args.backend)
        node = kind_cls(config)
        node_settings = getattr(node, "node_settings", node_settings)
        summary = run_node(
            node,
            node_settings,
            fabric,
            config,
            args.duration,
            stop,
            join_timeout_s=args.join_timeout,
        )
    except JoinRefused as exc:
        return fail("join", f"the authority refused {node_settings.node_id!r}: {exc}", 4)
    except FabricError as exc:
        return fail("join", str(exc), 3)
    except (ValueError, ConfigError) as exc:
        return fail("join", f"{args.kind}: {exc}")
    if summary.refused:
        return fail(
            "join", f"the authority refused {node_settings.node_id!r}: {summary.refused}", 4
        )
    if args.json:
        print_json(summary)
    else:
        print(
            f"{summary.node_id}: joined={summary.joined} saw {len(summary.actors_seen)} actor(s) "
            f"{summary.actors_seen}, sent {summary.poses_sent} poses in {summary.duration_s:.1f} s",
            file=sys.stderr,
        )
    return 0
