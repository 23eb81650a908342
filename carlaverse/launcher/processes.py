"""The launcher's children: `carlaverse` commands run as processes of their own, logs kept live.

Each is a `carlaverse.procs` child (its own process group, stdout and stderr read apart into one
live log, stopped SIGINT → SIGTERM → SIGKILL with its whole tree), kept here by name. No line
kept holds a URL's token: `?token=…` replaces it (`redact_tokens`); `on_stderr` sees a node's
own stderr lines before that (its HMI pairing URL, `launcher.hmi_pairing`).

    supervisor = Supervisor()
    supervisor.start("router", "router", ["router", "--listen", "tcp/127.0.0.1:7447"])
    supervisor.lines("router", since=0)      # (next index, new log lines)
    supervisor.stop_all()                     # nothing it started is left running
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable

from carlaverse import procs
from carlaverse.procs import Child

STOP_GRACE_S = 8.0  # [s] after SIGINT, the group is stopped
TOKEN_VALUE = re.compile(r"(?<=[?&]token=)[^\s&#]+")  # a credential in a URL's query


class LaunchError(ValueError):
    """A child cannot be started: a name already running, or an empty command."""


class Supervisor:
    """Starts `python -m carlaverse …` children and stops them with everything they started."""

    def __init__(self, command: list[str] | None = None, grace_s: float = STOP_GRACE_S) -> None:
        self.command = command or procs.carlaverse_command()
        self.grace_s = grace_s
        self.children: dict[str, Child] = {}
        self._lock = threading.Lock()

    def start(
        self, name: str, role: str, argv: list[str], on_stderr: Callable[[str], None] | None = None
    ) -> Child:
        """Run `carlaverse ARGV…` as `name`; LaunchError if `name` runs already.
        `on_stderr` sees each line of its stderr as written, before the log's redaction."""
        if not argv:
            raise LaunchError(f"{name}: no command to run")
        with self._lock:
            old = self.children.get(name)
            if old is not None and old.running:
                raise LaunchError(f"{name!r} is already running; stop it first")
            child = procs.start(
                argv,
                name=name,
                role=role,
                command=self.command,
                line_filter=redact_tokens,
                on_stderr=on_stderr,
                header=f"$ carlaverse {' '.join(argv)}",
            )
            self.children[name] = child
        return child

    def get(self, name: str) -> Child | None:
        with self._lock:
            return self.children.get(name)

    def snapshot(self) -> list[Child]:
        with self._lock:
            return list(self.children.values())

    def lines(self, name: str, since: int = 0) -> tuple[int, list[str]]:
        """The log lines of `name` numbered `since` and on, and the number after the last."""
        child = self.get(name)
        return (since, []) if child is None else child.log.since(since)

    def stop(self, name: str) -> None:
        child = self.get(name)
        if child is not None:
            procs.stop_children([child], self.grace_s)

    def stop_all(self) -> None:
        """Stop every child: nodes first, so they leave while the authority still answers."""
        children = self.snapshot()
        for role in ("node", "tool", "authority", "router"):
            procs.stop_children([c for c in children if c.role == role], self.grace_s)
        procs.stop_children(children, self.grace_s)  # a role not named above


def redact_tokens(line: str) -> str:
    """`line` with every URL's `token=` value replaced by `…`."""
    return TOKEN_VALUE.sub("…", line)
