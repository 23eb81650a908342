"""The `carlaverse` command line.

Each subcommand lives in its own module with two functions, `add_arguments(parser)` and
`run(args) -> int`, and is imported only when invoked, so a node host that lacks SUMO or rerun
can still run `carlaverse join`. Library code never exits; `main` is the only place that does.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from carlaverse import __version__
from carlaverse.cli.exit_codes import CliParser, Exit, summary
from carlaverse.cli.extras import install_hint

# name -> (module, one-line help). The module is imported lazily.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("carlaverse.cli.demo", "run a local demo session: router, authority, scripted nodes"),
    "launcher": ("carlaverse.cli.launcher", "web app: run a lab's session, configs, hardware"),
    "router": ("carlaverse.cli.router", "host a Zenoh router for a site"),
    "authority": ("carlaverse.cli.authority", "run the session authority (membership, world)"),
    "join": ("carlaverse.cli.join", "join a session as a node (observer, scripted, drive, ...)"),
    "stats": ("carlaverse.cli.stats", "per-node rate, latency, jitter and loss of a live session"),
    "config": ("carlaverse.cli.config_cmd", "validate configuration and scenario files"),
    "ffb-server": ("carlaverse.cli.ffb_server", "UDP force-feedback server with watchdog"),
    "motion-server": ("carlaverse.cli.motion_server", "UDP motion-platform server with watchdog"),
    "doctor": ("carlaverse.cli.doctor", "hardware diagnostics: joysticks, FFB and motion tests"),
    "calibrate": ("carlaverse.cli.calibrate", "measure a trainer's resistance table (YAML)"),
    "record": ("carlaverse.cli.record", "record every key of a session to MCAP"),
    "replay": ("carlaverse.cli.replay", "republish an MCAP recording into a live session"),
    "view": ("carlaverse.cli.view", "live Rerun view of a session or a recording"),
    "render": ("carlaverse.cli.render", "render a recorded moment (PNG) or clip (MP4) in 3D"),
    "analyze": (
        "carlaverse.cli.analyze",
        "trajectories and safety measures (TTC, PET) of a recording",
    ),
    "osi": ("carlaverse.cli.osi", "export a recording's ground truth as an ASAM OSI trace (MCAP)"),
    "audio": ("carlaverse.cli.audio", "render a recording's spatial audio for one listener (WAV)"),
    "certs": ("carlaverse.cli.certs", "generate a test CA and certificates for a lab"),
    "roster": ("carlaverse.cli.roster", "session roster tools: generate router ACLs"),
    "swarm": ("carlaverse.cli.swarm", "N synthetic egos in one process: load for the fabric"),
    "body": ("carlaverse.cli.body", "body pose: build the pose model, joint angles of a photo"),
    "schema": ("carlaverse.cli.schema", "print the wire contract: JSON Schema of every message"),
    "study": ("carlaverse.cli.study", "studies: validate, plan, run trials; participant agents"),
    "ros2": ("carlaverse.cli.ros2", "the session on ROS 2 over Zenoh: a view, or an AV as an ego"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = CliParser(
        prog="carlaverse",
        description="CARLAverse: share one live traffic world across labs over Zenoh.",
        epilog=summary(),
    )
    parser.add_argument("--version", action="version", version=f"carlaverse {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_module, help_text) in COMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def _command_parser(name: str) -> tuple[argparse.ArgumentParser, ModuleType]:
    module_name, help_text = COMMANDS[name]
    module = importlib.import_module(module_name)
    parser = CliParser(prog=f"carlaverse {name}", description=help_text)
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv)")
    module.add_arguments(parser)
    return parser, module


def _zenoh_logs() -> None:
    """Zenoh's own log (a failed TLS handshake is otherwise silent); RUST_LOG overrides."""
    try:
        import zenoh
    except ModuleNotFoundError:
        return
    zenoh.init_log_from_env_or("info")


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    top = build_parser()
    # Split at the subcommand so each command owns its own flags and --help.
    first = next((i for i, a in enumerate(argv) if not a.startswith("-")), None)
    if first is None:
        top.parse_args(argv)
        top.print_help()
        return Exit.USAGE
    name = argv[first]
    if name not in COMMANDS:
        top.parse_args(argv)  # argparse reports the unknown command with choices
        return Exit.USAGE
    top_args = top.parse_args(argv[:first])
    try:
        parser, module = _command_parser(name)
    except ModuleNotFoundError as exc:
        return _missing_extra(name, exc)
    args = parser.parse_args(argv[first + 1 :])
    verbosity = max(top_args.verbose, args.verbose)
    level = logging.WARNING if verbosity == 0 else logging.INFO if verbosity == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if verbosity >= 2:
        _zenoh_logs()
    # pygame greets on stdout when imported (a drive node's keyboard, a wheel): stdout is
    # the command's, and with --json its one JSON document.
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        return int(module.run(args) or 0)
    except KeyboardInterrupt:
        return Exit.SIGINT
    except ModuleNotFoundError as exc:  # an extra's package, imported when first needed
        return _missing_extra(name, exc)


def _missing_extra(command: str, exc: ModuleNotFoundError) -> int:
    """Say in one line which `pip install` brings the missing package (exit 2, as for any
    usage or install problem); a missing module no extra brings is a bug: raised on."""
    hint = install_hint(exc.name)
    if hint is None:
        raise exc
    package = (exc.name or "").partition(".")[0]
    print(f"carlaverse {command}: needs {package}: {hint}", file=sys.stderr)
    return 2
