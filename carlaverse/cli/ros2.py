"""`carlaverse ros2 view|av`: the session on ROS 2 over Zenoh (rmw_zenoh's keys and CDR).

    carlaverse ros2 view --session lab --connect tcp/127.0.0.1:7447
    carlaverse ros2 av --id av-1 --session lab --connect tcp/127.0.0.1:7447 \\
        --odom-topic /av/odom --actor-kind car --extent 4.6,1.9,1.5

Both join the session like any node (exit codes as `join`); docs/protocol.md ("ROS 2 over
Zenoh") lists the topics, frames and units.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from typing import Any, TextIO

import msgspec

from carlaverse.cli.common import (
    add_fabric_args,
    add_output_args,
    fabric_from_args,
    fail,
    json_stdout,
    print_json,
    say,
    stop_on_signals,
)
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError, load_config
from carlaverse.keys import KeySpaceError, check_token
from carlaverse.messages import ACTOR_KINDS, Extent
from carlaverse.node_runtime import JoinTimeout, NodeSummary, run_node
from carlaverse.ros2.av_participant import (
    AvConfig,
    AvParticipantNode,
    AvSettings,
    await_odometry,
)
from carlaverse.ros2.bridge import Ros2BridgeConfig, Ros2BridgeNode, Ros2Settings
from carlaverse.ros2.keys import RosNameError
from carlaverse.transport.node_client import JoinRefused
from carlaverse.transport.session import (
    FabricError,
    FabricUnreachable,
    build_config,
    open_session,
)

KINDS = {"view": Ros2BridgeNode, "av": AvParticipantNode}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "The session on ROS 2 over Zenoh, in rmw_zenoh's key and CDR format: a ROS 2 "
        "installation with RMW_IMPLEMENTATION=rmw_zenoh_cpp whose router reaches this "
        "session's sees its topics. `view` publishes the world; `av` makes a ROS 2 stack's "
        "nav_msgs/Odometry an ego of the session and gives it the world and its collisions."
    )
    parser.epilog = "Topics, frames and units: docs/protocol.md, section 'ROS 2 over Zenoh'."
    sub = parser.add_subparsers(dest="role", metavar="ROLE", required=True)
    view = sub.add_parser("view", help="publish the session as ROS 2 topics (an observer)")
    av = sub.add_parser(
        "av", help="join a ROS 2 AV as an ego once its Odometry topic publishes",
        description="Wait for the AV's first nav_msgs/Odometry, then join the session as an "
        "ego (its id, actor kind, extent) whose poses are that odometry; publish its "
        "collisions and, unless --no-world, the world. Quiet for the despawn timeout: "
        "despawned like any silent node.",
    )  # fmt: skip
    for role in (view, av):
        role.add_argument("--id", dest="node_id", help="node id in the session")
        role.add_argument("--config", help="YAML with node:, fabric:, ros2: (and av:) sections")
        role.add_argument("--domain", type=int, help="ROS_DOMAIN_ID (default 0)")
        role.add_argument("--rate", type=float, help="world topics per second (default 20)")
        role.add_argument("--prefix", help="namespace of the session's topics (/carlaverse)")
        role.add_argument("--join-timeout", type=float, metavar="S",
                          help="give up (exit 5) when not admitted after S seconds")  # fmt: skip
        add_fabric_args(role)
        add_output_args(role)
    av.add_argument("--odom-topic", help="the AV's nav_msgs/Odometry topic (default /av/odom)")
    av.add_argument("--actor-kind", choices=ACTOR_KINDS, help="what the AV is (default car)")
    av.add_argument("--extent", metavar="L,W,H", help="the AV's box [m], e.g. 4.6,1.9,1.5")
    av.add_argument("--no-world", action="store_true",
                    help="publish only the AV's collisions, not the world (when a `ros2 view` "
                    "serves the same domain: /clock and /tf would come from both)")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    command = f"ros2 {args.role}"
    try:
        config = _config(args)
    except (ConfigError, KeySpaceError, FabricError, RosNameError, ValueError) as exc:
        return fail(command, str(exc).lstrip(": "))
    stop = stop_on_signals()
    node = KINDS[args.role](config)
    duration = args.duration
    try:
        if isinstance(config, AvConfig):
            started = time.monotonic()
            if not _odometry_heard(command, config, stop, duration):
                return fail(command, f"no odometry on {config.av.odom_topic} "
                            f"(ROS_DOMAIN_ID {config.ros2.domain_id}): never joined",
                            stop.exit_code() if stop.is_set() else Exit.NOT_ADMITTED)  # fmt: skip
            if duration is not None:
                duration = max(0.0, duration - (time.monotonic() - started))
        summary = run_node(
            node, config.node, config.fabric, config, duration, stop,
            join_timeout_s=args.join_timeout, on_wait=say(command),
        )  # fmt: skip
    except JoinRefused as exc:
        return fail(command, f"the authority refused {config.node.node_id!r}: {exc}", Exit.REFUSED)
    except (FabricUnreachable, JoinTimeout) as exc:
        code = stop.exit_code() if stop.is_set() else Exit.NOT_ADMITTED
        return fail(command, f"not admitted: {exc}", code)
    except FabricError as exc:
        return fail(command, str(exc), Exit.FABRIC)
    return _report(command, args, summary, out)


def _odometry_heard(
    command: str, config: AvConfig, stop: threading.Event, duration: float | None
) -> bool:
    """Wait for the AV's first odometry on a session of its own, saying so once."""
    say(command)(f"waiting for nav_msgs/Odometry on {config.av.odom_topic} before joining")
    deadline = None if duration is None else time.monotonic() + duration
    session = open_session(config.fabric, stop, deadline, say(command))
    try:
        left = None if deadline is None else max(0.0, deadline - time.monotonic())
        return await_odometry(session, config, stop, left)
    finally:
        session.close()


def _config(args: argparse.Namespace) -> AvConfig | Ros2BridgeConfig:
    """The role's config: its file, then the flags; errors name the flag or the field."""
    config: AvConfig | Ros2BridgeConfig
    if args.role == "av":
        config = load_config(args.config, AvConfig) if args.config else AvConfig()
    else:
        config = load_config(args.config, Ros2BridgeConfig) if args.config else Ros2BridgeConfig()
    node = config.node
    node_changes: dict[str, Any] = {}
    if args.node_id:
        node_changes["node_id"] = args.node_id
    if args.session:
        node_changes["session"] = args.session
    if args.role == "av":
        if args.actor_kind:
            node_changes["actor_kind"] = args.actor_kind
        if args.extent:
            node_changes["extent"] = _extent(args.extent)
    node = msgspec.structs.replace(node, **node_changes)
    if not node.node_id:
        node = msgspec.structs.replace(node, node_id="ros2-view") if args.role == "view" else node
    if not node.node_id:
        raise ConfigError("--id", "no node id: pass --id NODE_ID or set node.node_id")
    check_token(node.node_id)
    check_token(node.session, "session name")
    fabric = fabric_from_args(args, config.fabric, identity=node.node_id)
    build_config(fabric)
    ros2 = _ros2(args, config.ros2)
    changes: dict[str, Any] = {"node": node, "fabric": fabric, "ros2": ros2}
    if isinstance(config, AvConfig):
        av = config.av
        changes["av"] = AvSettings(args.odom_topic or av.odom_topic, av.odom_timeout_s,
                                   av.world and not args.no_world)  # fmt: skip
    return msgspec.convert(
        msgspec.to_builtins(msgspec.structs.replace(config, **changes)), type(config)
    )  # converted again, so the settings' own checks run on the flags' values too


def _ros2(args: argparse.Namespace, base: Ros2Settings) -> Ros2Settings:
    changes: dict[str, Any] = {}
    if args.domain is not None:
        changes["domain_id"] = args.domain
    if args.rate is not None:
        changes["rate_hz"] = args.rate
    if args.prefix:
        changes["prefix"] = args.prefix
    return msgspec.structs.replace(base, **changes)


def _extent(text: str) -> Extent:
    try:
        length, width, height = (float(v) for v in text.split(","))
    except ValueError:
        raise ConfigError("--extent", f"{text!r}: three lengths in metres, L,W,H") from None
    if not all(0 < v < 50 for v in (length, width, height)):
        raise ConfigError("--extent", f"{text!r}: each length between 0 and 50 m")
    return Extent(length, width, height)


def _report(command: str, args: argparse.Namespace, summary: NodeSummary, out: TextIO) -> int:
    if args.json:
        print_json(summary, out)
    if not summary.joined:
        return fail(command, f"not admitted: {summary.waiting_for}", Exit.NOT_ADMITTED)
    if not args.json:
        print(f"{summary.node_id}: saw {len(summary.actors_seen)} actor(s), "
              f"{summary.extra}", file=sys.stderr)  # fmt: skip
    return Exit.OK
