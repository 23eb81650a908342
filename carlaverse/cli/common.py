"""Flags and plumbing every fabric command shares: endpoints, session, stop signals, output."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, TextIO

import msgspec

from carlaverse.cli.exit_codes import Exit
from carlaverse.keys import Keys
from carlaverse.transport.session import FabricSettings, open_session, reachable
from carlaverse.transport.waiting import SessionWait, WaitNotice


def add_fabric_args(parser: argparse.ArgumentParser, session: bool = True) -> None:
    group = parser.add_argument_group("fabric")
    if session:
        group.add_argument("--session", help="session name (default: from config, else 'default')")
    group.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="EP",
        help="Zenoh endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable)",
    )
    group.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="EP",
        help="Zenoh endpoint to listen on (repeatable; default tcp/127.0.0.1:0, loopback only)",
    )
    group.add_argument(
        "--mode",
        choices=["peer", "client"],
        help="Zenoh mode (default: peer when every --connect endpoint is on this host, else "
        "client, since peers on different hosts of a site do not hear each other)",
    )
    group.add_argument(
        "--roster",
        metavar="FILE",
        help="secured session roster: join with this node's certificate and login as a "
        "client of its site router (see router/README.md)",
    )
    group.add_argument(
        "--lowlatency",
        action="store_true",
        help="Zenoh low-latency transport (every process on the path must use it)",
    )


def fabric_from_args(
    args: argparse.Namespace, base: FabricSettings | None = None, identity: str | None = None
) -> FabricSettings:
    """Settings from a config section overridden by flags. With `--roster`, the TLS and login
    entries of `identity` (default: `--id`) are added; raises ConfigError if they are missing."""
    base = base or FabricSettings()
    changes: dict[str, Any] = {}
    if args.connect:
        changes["connect"] = list(args.connect)
    if args.listen:
        changes["listen"] = list(args.listen)
    if getattr(args, "mode", None):
        changes["mode"] = args.mode
    if getattr(args, "lowlatency", False):
        changes["lowlatency"] = True
    settings = msgspec.structs.replace(base, **changes)
    if not getattr(args, "mode", None):  # an explicit --mode is kept whatever it means
        settings = reachable(settings)
    if getattr(args, "roster", None):
        from carlaverse.security.sites import secure_fabric

        node_id = identity or getattr(args, "node_id", None)
        settings = secure_fabric(settings, args.roster, node_id, keep_mode=bool(args.mode))
    return settings


def add_output_args(parser: argparse.ArgumentParser, duration: float | None = None) -> None:
    parser.add_argument(
        "--duration",
        type=float,
        default=duration,
        metavar="S",
        help=f"stop after S seconds (default {duration:g})" if duration else "stop after S seconds",
    )
    parser.add_argument(
        "--json", action="store_true", help="print a machine-readable summary at exit"
    )


class StopSignal(threading.Event):
    """Set by SIGINT or SIGTERM; remembers which, for the conventional exit code 128 + N."""

    signum: int = 0

    def exit_code(self) -> Exit:
        return Exit.stopped_by(self.signum or signal.SIGINT)


def stop_on_signals(then: Callable[[], None] | None = None) -> StopSignal:
    """An event set by SIGINT or SIGTERM, so loops end cleanly and leave the session; `then`
    is also called from the handler (it must not wait: a server's stop flag)."""
    stop = StopSignal()

    def handler(signum: int, frame: object) -> None:
        stop.signum = signum
        stop.set()
        if then is not None:
            then()

    if threading.current_thread() is threading.main_thread():  # tests call main() off it
        signal.signal(signal.SIGINT, handler)
        signal.signal(signal.SIGTERM, handler)
    return stop


def tell(text: str) -> None:
    """One line on stderr in one write: `print` writes the text and its newline apart, and a
    log line from another thread can land between them, gluing two lines together."""
    sys.stderr.write(text + "\n")
    sys.stderr.flush()


def say(command: str) -> Callable[[str], None]:
    """A one-line notice on stderr, `carlaverse COMMAND: ...`, for what a command waits for."""

    def notice(message: str) -> None:
        tell(f"carlaverse {command}: {message}")

    return notice


def print_json(value: Any, out: TextIO | None = None) -> None:
    """The command's one JSON document, on `out` (from `json_stdout`) or stdout."""
    stream = sys.stdout if out is None else out
    stream.write(to_json(value) + "\n")
    stream.flush()


@contextlib.contextmanager
def json_stdout(enabled: bool) -> Iterator[TextIO]:
    """While a `--json` command runs, whatever else would reach stdout goes to stderr; yields
    the stream for its one JSON document (stdout as it was). Without `enabled`, stdout as is.

    Why at the file-descriptor level: a library greeting on import (pygame's banner), a C
    library's printf and a child process (a node's control loop) all write to fd 1 without
    passing through `sys.stdout`. So fd 1 is pointed at stderr for the whole run and the
    document goes to a duplicate of the original fd 1; `sys.stdout` follows fd 1 to stderr.
    """
    if not enabled:
        yield sys.stdout
        return
    python_stdout = sys.stdout
    python_stdout.flush()
    saved = os.dup(1)
    # sys.stdout on fd 1 is about to lead to stderr: the document goes to the duplicate
    # (a pytest capture or a StringIO in sys.stdout is not fd 1 and keeps the document).
    own = None
    if _is_fd_1(python_stdout):
        own = open(saved, "w", encoding="utf-8", closefd=False)  # noqa: SIM115 (closed below)
    try:
        os.dup2(2, 1)
        sys.stdout = sys.stderr
        yield python_stdout if own is None else own
    finally:
        sys.stdout = python_stdout
        with contextlib.suppress(ValueError, OSError):
            sys.stderr.flush()
        if own is not None:
            own.close()  # flushes; the duplicate fd stays open until restored below
        os.dup2(saved, 1)
        os.close(saved)


def _is_fd_1(stream: TextIO) -> bool:
    try:
        return stream.fileno() == 1
    except (OSError, ValueError, io.UnsupportedOperation):  # a pytest capture, a StringIO
        return False


def to_json(value: Any) -> str:
    """Strict JSON for --json outputs: a figure never measured (NaN, infinity) becomes null."""
    return json.dumps(
        _finite(msgspec.to_builtins(value)), indent=2, sort_keys=True, allow_nan=False
    )


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def fail(command: str, message: str, code: int = Exit.USAGE) -> int:
    """Say what went wrong in one line, `carlaverse COMMAND: ...`; the code to exit with."""
    tell(f"carlaverse {command}: {message}")
    return code


def attend(
    command: str,
    fabric: FabricSettings,
    keys: Keys,
    stop: threading.Event,
    deadline: float | None = None,
) -> tuple[Any, WaitNotice]:
    """Open the session for a recorder, viewer or observer and keep saying what it waits for.

    A client waits for its router (one line within ~1 s; FabricUnreachable when `stop` is
    set or the monotonic `deadline` passes); then a background notice says, once per change,
    if no router or no authority of the session is there. Close the notice before the session.
    """
    notice_line = say(command)
    session = open_session(fabric, stop, deadline, notice_line)
    try:
        notice = WaitNotice(SessionWait(session, fabric, keys), notice_line).start()
    except BaseException:
        session.close()
        raise
    return session, notice


def reached_nothing(notice: WaitNotice, fabric: FabricSettings) -> str | None:
    """For a recorder or observer at its end (session still open): the line saying that no
    router or peer was reached for its whole run, so it saw nothing because of the network;
    None when one was."""
    if notice.wait.reached.is_set() or notice.wait.reaches_anyone():
        return None
    where = ", ".join(fabric.connect) or "any endpoint (none given with --connect)"
    return f"reached no router or peer at {where}"


@dataclass
class Companion:
    """What `join` runs beside a node (its view, HMI or audio), if anything; `report` holds
    its summary once it has closed, which goes into the node's exit summary as `name`."""

    name: str
    running: Any = None  # the view or audio process, the HMI server
    report: dict[str, Any] = field(default_factory=dict)

    @property
    def extra(self) -> dict[str, Any]:
        """What the node's exit summary gets: {name: report} when it ran."""
        return {self.name: self.report} if self.report else {}
