"""`carlaverse join KIND`: join a session as a node of the given kind."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any, TextIO

import msgspec

from carlaverse.cli.audio import add_audio_argument, node_audio
from carlaverse.cli.common import (
    Companion,
    StopSignal,
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
from carlaverse.cli.join_hmi import add_hmi_arguments, hmi_questionnaires, node_hmi
from carlaverse.cli.join_view import add_view_arguments, node_view
from carlaverse.config import ConfigError, load_config
from carlaverse.keys import KeySpaceError, check_token
from carlaverse.messages import Notice
from carlaverse.node_runtime import (
    JoinTimeout,
    NodeSummary,
    UnknownNodeKind,
    load_node_kind,
    node_kinds,
    run_node,
)
from carlaverse.shm import BlockInUse
from carlaverse.transport.node_client import JoinRefused, NodeSettings
from carlaverse.transport.session import (
    FabricError,
    FabricSettings,
    FabricUnreachable,
    build_config,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Join a session as a node. Kinds are plug-ins (entry-point group carlaverse.nodes); "
        f"installed: {', '.join(sorted(node_kinds()))}."
    )
    parser.epilog = (
        "Until the authority admits it the node says what it waits for and keeps trying, "
        "opening the session included: --join-timeout bounds the whole wait. Exit codes "
        "(docs/protocol.md): 2 usage or config error, 3 fabric error, 4 refused by the "
        "authority, 5 not admitted in time (--join-timeout or --duration; an authority that "
        "does not answer is waited for, not a refusal), 130/143 stopped by SIGINT/SIGTERM "
        "before it was admitted. With --json, stdout holds the one summary and nothing else."
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
        metavar="S",
        help="give up (exit 5) if the authority has not admitted the node after S seconds "
        "(default: keep trying for the whole --duration)",
    )
    add_fabric_args(parser)
    add_output_args(parser)
    add_view_arguments(parser)
    add_audio_argument(parser)
    add_hmi_arguments(parser)


def _prepare(args: argparse.Namespace) -> tuple[type, Any, NodeSettings, FabricSettings]:
    """The kind, its config with --id/--session/fabric flags applied; ConfigError-like errors."""
    kind_cls = load_node_kind(args.kind)
    # Each kind's own config type; NodeKind promises only its `node` and `fabric` sections.
    config: Any = (
        load_config(args.config, kind_cls.config_type) if args.config else kind_cls.config_type()
    )
    node_settings = config.node
    if args.node_id:
        node_settings = msgspec.structs.replace(node_settings, node_id=args.node_id)
    if args.session:
        node_settings = msgspec.structs.replace(node_settings, session=args.session)
    if not node_settings.node_id:
        raise ConfigError("", "no node id: pass --id NODE_ID or set node.node_id in the config")
    check_token(node_settings.node_id)
    check_token(node_settings.session, "session name")
    fabric = fabric_from_args(args, config.fabric, identity=node_settings.node_id)
    build_config(fabric)  # endpoints and Zenoh entries checked before any device starts
    config = msgspec.structs.replace(config, node=node_settings, fabric=fabric)
    if args.backend:
        if not hasattr(kind_cls, "with_backend"):
            raise ConfigError("", f"node kind {args.kind!r} has no devices for --backend")
        config = kind_cls.with_backend(config, args.backend)
    return kind_cls, config, node_settings, fabric


def _show_notice(hmi: Companion, say_line: Callable[[str], None]) -> Callable[[Notice], None]:
    """A scenario's message for this participant: on its HMI when it has one, and a line."""

    def show(notice: Notice) -> None:
        if hmi.running is not None:
            hmi.running.show_message(notice.text, notice.duration_s)
        say_line(f"scenario message: {notice.text}")

    return show


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:  # a device library's banner must not reach it
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    try:
        kind_cls, config, node_settings, fabric = _prepare(args)
    except (UnknownNodeKind, ConfigError, KeySpaceError, FabricError) as exc:
        return fail("join", str(exc).lstrip(": "))
    stop = stop_on_signals()
    node_id = node_settings.node_id
    try:
        node = kind_cls(config)
        node_settings = getattr(node, "node_settings", node_settings)
        with (
            node_view(args, node, node_settings, fabric) as view,  # --view: its own process
            node_hmi(args, args.kind, node, say("join"), node_settings) as hmi,  # a thread
            node_audio(args, node, node_id) as audio,  # --audio: a process the client feeds
        ):
            summary = run_node(
                node, node_settings, fabric, config, args.duration, stop,
                join_timeout_s=args.join_timeout, on_wait=say("join"),
                on_notice=_show_notice(hmi, say("join")), audio=audio.running,
                on_session=hmi_questionnaires(hmi, node_settings.node_id),
            )  # fmt: skip
        summary.extra.update(view.extra | hmi.extra | audio.extra)
    except JoinRefused as exc:
        return fail("join", f"the authority refused {node_id!r}: {exc}", Exit.REFUSED)
    except (FabricUnreachable, JoinTimeout) as exc:
        if stop.is_set():
            return fail("join", f"stopped before it was admitted ({exc})", stop.exit_code())
        return fail("join", f"{node_id} gave up: {_stopped_waiting(exc)}", Exit.NOT_ADMITTED)
    except FabricError as exc:
        return fail("join", str(exc), Exit.FABRIC)
    except (ValueError, ConfigError, BlockInUse) as exc:
        return fail("join", f"{args.kind}: {exc}")
    return _report(args, summary, stop, out)


def _stopped_waiting(exc: Exception) -> str:
    if isinstance(exc, JoinTimeout):
        return f"not admitted within --join-timeout: {exc}"
    return str(exc)


def _counted(summary: NodeSummary) -> str:
    """`; dropped {...}, rejected {...}` for the counters that are not empty."""
    parts = [f"{name} {counts}" for name, counts in (
        ("dropped", summary.dropped), ("rejected", summary.rejected),
        ("handler errors", summary.handler_errors)) if counts]  # fmt: skip
    return "; " + ", ".join(parts) if parts else ""


def _still(summary: NodeSummary) -> str:
    return f"still {summary.waiting_for}"


def _report(args: argparse.Namespace, summary: NodeSummary, stop: StopSignal, out: TextIO) -> int:
    if summary.refused:
        return fail(
            "join", f"the authority refused {summary.node_id!r}: {summary.refused}", Exit.REFUSED
        )
    if args.json:
        print_json(summary, out)
    if not summary.joined:
        if stop.is_set():
            return fail("join", f"stopped before it was admitted, {_still(summary)}",
                        stop.exit_code())  # fmt: skip
        return fail(
            "join", f"not admitted in {summary.duration_s:.0f} s, {_still(summary)}",
            Exit.NOT_ADMITTED,
        )  # fmt: skip
    if not args.json:
        print(
            f"{summary.node_id}: joined={summary.joined} saw {len(summary.actors_seen)} actor(s) "
            f"{summary.actors_seen}, sent {summary.poses_sent} poses in {summary.duration_s:.1f} s"
            + _counted(summary),
            file=sys.stderr,
        )
    return Exit.OK
