"""The launcher's children: `carlaverse` commands run as processes of their own, logs kept live.

Each child runs in its own process group (a new session), so a Ctrl-C typed at the launcher's
terminal does not reach it behind the launcher's back, and stopping it reaches its whole tree:
SIGINT to the child first (every command shuts down cleanly on it — a node leaves, a recorder
closes its file — and stops its own helpers, such as a drive node's loop process, in order),
then SIGKILL to the group and to any descendant that left it, after a grace.

Its stdout and stderr are read apart, each line into one live log (the two streams' order
is kept within each, approximately between them), so a caller may watch stderr alone for a
line only the command itself writes there (`on_stderr`: a node's HMI pairing URL). No line
kept holds a URL's token: `?token=…` replaces it (`redact_tokens`).

    supervisor = Supervisor()
    supervisor.start("router", "router", ["router", "--listen", "tcp/127.0.0.1:7447"])
    supervisor.lines("router", since=0)      # (next index, new log lines)
    supervisor.stop_all()                     # nothing it started is left running
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO

import psutil

LOG_LINES = 2000  # lines kept per child; older ones scroll away
STOP_GRACE_S = 8.0  # [s] after SIGINT, the group is killed
TOKEN_VALUE = re.compile(r"(?<=[?&]token=)[^\s&#]+")  # a credential in a URL's query


class LaunchError(ValueError):
    """A child cannot be started: a name already running, or an empty command."""


@dataclass
class Child:
    """One started command and the lines of its stdout and stderr, numbered from 0."""

    name: str
    role: str  # router | authority | node | tool
    argv: list[str]
    proc: subprocess.Popen[str]
    log: deque[str] = field(default_factory=lambda: deque(maxlen=LOG_LINES))
    first_line: int = 0  # the index of log[0]: lines scrolled away are still counted
    lock: threading.Lock = field(default_factory=threading.Lock)

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    @property
    def exit_code(self) -> int | None:
        return self.proc.poll()

    def add_line(self, line: str) -> None:
        with self.lock:
            if len(self.log) == self.log.maxlen:
                self.first_line += 1
            self.log.append(redact_tokens(line.rstrip("\n")))

    def lines_since(self, index: int) -> tuple[int, list[str]]:
        """The lines numbered `index` and on, and the index after the last."""
        with self.lock:
            start = max(0, index - self.first_line)
            return self.first_line + len(self.log), list(self.log)[start:]


class Supervisor:
    """Starts `python -m carlaverse …` children and stops them with everything they started."""

    def __init__(self, command: list[str] | None = None, grace_s: float = STOP_GRACE_S) -> None:
        # what runs `carlaverse`: this interpreter, so a venv's launcher starts the venv's nodes
        self.command = command or [sys.executable, "-m", "carlaverse"]
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
            env = dict(os.environ, PYTHONUNBUFFERED="1")
            proc = subprocess.Popen(
                [*self.command, *argv],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                env=env,
                start_new_session=True,  # its own process group: stopped as a whole tree
            )
            child = Child(name, role, list(argv), proc)
            child.add_line(f"$ carlaverse {' '.join(argv)}")
            self.children[name] = child
        pumps = [_Pump(child, proc.stdout), _Pump(child, proc.stderr, on_stderr)]
        threading.Thread(target=_follow, args=(child, pumps), daemon=True).start()
        return child

    def get(self, name: str) -> Child | None:
        with self._lock:
            return self.children.get(name)

    def snapshot(self) -> list[Child]:
        with self._lock:
            return list(self.children.values())

    def lines(self, name: str, since: int = 0) -> tuple[int, list[str]]:
        child = self.get(name)
        return (since, []) if child is None else child.lines_since(since)

    def stop(self, name: str) -> None:
        child = self.get(name)
        if child is not None:
            stop_children([child], self.grace_s)

    def stop_all(self) -> None:
        """Stop every child: nodes first, so they leave while the authority still answers."""
        children = self.snapshot()
        for role in ("node", "tool", "authority", "router"):
            stop_children([c for c in children if c.role == role], self.grace_s)
        stop_children(children, self.grace_s)  # a role not named above


def redact_tokens(line: str) -> str:
    """`line` with every URL's `token=` value replaced by `…`."""
    return TOKEN_VALUE.sub("…", line)


class _Pump(threading.Thread):
    """Copies one of a child's streams into its log, line by line, until the stream closes."""

    def __init__(
        self, child: Child, stream: IO[str] | None, watch: Callable[[str], None] | None = None
    ) -> None:
        super().__init__(name=f"log-{child.name}", daemon=True)
        self.child, self.stream, self.watch = child, stream, watch

    def run(self) -> None:
        if self.stream is None:
            return
        for line in self.stream:
            if self.watch is not None:
                self.watch(line)
            self.child.add_line(line)


def _follow(child: Child, pumps: list[_Pump]) -> None:
    """Both streams into the log, then the exit code as its last line."""
    for pump in pumps:
        pump.start()
    for pump in pumps:
        pump.join()
    child.add_line(f"[exited with code {child.proc.wait()}]")


def stop_children(children: list[Child], grace_s: float) -> None:
    """SIGINT each running child at once; SIGKILL what is left of each tree after `grace_s`.
    Returns when every process of those trees has gone."""
    trees = {c.name: _tree(c.proc.pid) for c in children if c.running}
    for child in children:
        if child.name in trees:
            child.proc.send_signal(signal.SIGINT)  # its helpers are its to stop, in order
    deadline = time.monotonic() + grace_s
    for child in children:
        if child.name not in trees:
            continue
        try:
            child.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            _signal_group(child.proc.pid, signal.SIGKILL)
            child.proc.wait()
        _kill_left(trees[child.name], deadline)


def _tree(pid: int) -> list[psutil.Process]:
    """The process and its descendants now, so those that leave its group are still found."""
    try:
        root = psutil.Process(pid)
        return [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return []


def _signal_group(pgid: int, signum: signal.Signals) -> None:
    try:
        os.killpg(pgid, signum)
    except ProcessLookupError:
        pass  # the group has gone already


def _kill_left(tree: list[psutil.Process], deadline: float) -> None:
    """Wait out the grace for descendants still alive, then kill them."""
    alive = [p for p in tree if _alive(p)]
    _gone, alive = psutil.wait_procs(alive, timeout=max(0.0, deadline - time.monotonic()))
    for process in alive:
        try:
            process.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(alive, timeout=2.0)


def _alive(process: psutil.Process) -> bool:
    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False
