"""Child processes, one way: started in a process group of their own, their output read line
by line per stream, waited on for a ready line with a deadline, stopped whatever they do.

`carlaverse demo`, the launcher, the tests and the benchmarks start `carlaverse` commands (and
other programs) through `start`:

    child = start(["router", "--listen", "tcp/127.0.0.1:7447"], name="router")
    child.wait_for_line(lambda line: line.startswith("router "), timeout_s=30)
    stop_children([child])             # SIGINT, then SIGTERM, then SIGKILL, with deadlines
    summary = child.json()             # the JSON document it printed on stdout, if any

Each child runs in its own process group (a new session), so a Ctrl-C typed at the parent's
terminal does not reach it behind the parent's back, and stopping it reaches its whole tree:
SIGINT to the child first (every command shuts down cleanly on it — a node leaves, a recorder
closes its file — and stops its own helpers in order), SIGTERM to its group after a grace,
SIGKILL to the group and to any descendant that left it after a shorter one.

Its stdout and stderr are read apart, each into a bounded log of its own (`out`, `err`) and
both into one (`log`, the two streams' order kept within each, approximately between them), so
a caller may watch stderr alone for a line only the command itself writes there. A filter may
rewrite every line kept (the launcher's hides URL tokens); `on_stderr` sees each line first.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO, Any

LOG_LINES = 2000  # lines kept per log; older ones scroll away
STOP_GRACE_S = 8.0  # [s] from SIGINT to SIGTERM
TERM_GRACE_S = 2.0  # [s] from SIGTERM to SIGKILL
READ_TAIL_S = 2.0  # [s] for the readers to take an exited child's last lines
POLL_S = 0.05  # [s] how often a wait looks at the child and the stop event


class ChildFailed(RuntimeError):
    """A child exited, or stayed silent past its deadline, before the line it was waited for."""


def free_port(host: str = "127.0.0.1", udp: bool = False) -> int:
    """A TCP (or UDP) port free on `host` now (the kernel's pick; another program may take
    it before the caller binds it)."""
    kind = socket.SOCK_DGRAM if udp else socket.SOCK_STREAM
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def carlaverse_command() -> list[str]:
    """What runs `carlaverse`: this interpreter, so a venv's caller starts the venv's commands."""
    return [sys.executable, "-m", "carlaverse"]


class LineLog:
    """Lines numbered from 0; past `maxlen` the oldest scroll away but are still counted."""

    def __init__(self, maxlen: int = LOG_LINES) -> None:
        self._lines: deque[str] = deque(maxlen=maxlen)
        self._first = 0  # the number of _lines[0]
        self._changed = threading.Condition()

    def append(self, line: str) -> None:
        with self._changed:
            if len(self._lines) == self._lines.maxlen:
                self._first += 1
            self._lines.append(line)
            self._changed.notify_all()

    def since(self, index: int) -> tuple[int, list[str]]:
        """The lines numbered `index` and on (those still kept), and the number after the last."""
        with self._changed:
            start = max(0, index - self._first)
            return self._first + len(self._lines), list(self._lines)[start:]

    def lines(self) -> list[str]:
        with self._changed:
            return list(self._lines)

    def text(self) -> str:
        return "\n".join(self.lines())

    def wait_past(self, index: int, timeout_s: float) -> None:
        """Return once a line numbered `index` or later exists, or after `timeout_s`."""
        with self._changed:
            self._changed.wait_for(lambda: self._first + len(self._lines) > index, timeout_s)


@dataclass
class Child:
    """One started process and its lines of stdout and stderr (`log` ends with its exit)."""

    name: str
    role: str  # what the caller calls it: router | authority | node | tool | ...
    argv: list[str]
    proc: subprocess.Popen[str]
    out: LineLog
    err: LineLog
    log: LineLog  # both streams
    readers: list[threading.Thread] = field(default_factory=list)

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    @property
    def exit_code(self) -> int | None:
        return self.proc.poll()

    def finish_reading(self, timeout_s: float = READ_TAIL_S) -> None:
        """Let the readers take the last lines of an exited child (its pipes close)."""
        deadline = time.monotonic() + timeout_s
        for reader in self.readers:
            reader.join(max(0.0, deadline - time.monotonic()))

    def wait_exit(self, timeout_s: float) -> int | None:
        """Wait up to `timeout_s` for the child to exit, then for its last lines; its exit code
        (None: it is still running)."""
        try:
            self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            return None
        self.finish_reading()
        return self.proc.returncode

    def last_error(self) -> str:
        """The last non-empty stderr line: a command's one-line error says why it failed."""
        lines = [line.strip() for line in self.err.lines() if line.strip()]
        return lines[-1] if lines else ""

    def json(self) -> Any:
        """The JSON document this child printed on stdout (None if none): call once it exited."""
        self.finish_reading()
        return parse_json(self.out.lines())

    def wait_for_line(
        self,
        match: str | Callable[[str], bool],
        timeout_s: float,
        stream: str = "err",
        stop: threading.Event | None = None,
    ) -> str | None:
        """The first line of `stream` ("out", "err" or "both") that starts with `match` (or that
        `match` accepts). ChildFailed naming the child if it exits first or `timeout_s` passes;
        None if `stop` is set meanwhile (the caller is stopping everything)."""
        accept = match if callable(match) else _prefix(match)
        log = {"out": self.out, "err": self.err, "both": self.log}[stream]
        deadline = time.monotonic() + timeout_s
        index = 0
        while True:
            index, lines = log.since(index)
            found = next((line for line in lines if accept(line)), None)
            if found is not None:
                return found
            if stop is not None and stop.is_set():
                return None
            if not self.running and not any(r.is_alive() for r in self.readers):
                raise ChildFailed(f"the {self.name} exited ({self.exit_code}): {self.last_error()}")
            left = deadline - time.monotonic()
            if left <= 0:
                raise ChildFailed(f"the {self.name} did not start within {timeout_s:.0f} s")
            log.wait_past(index, min(POLL_S, left))

    def stop(self, grace_s: float = STOP_GRACE_S) -> int:
        """Stop this child (see `stop_children`); its exit code."""
        stop_children([self], grace_s)
        return self.proc.wait()


def start(
    argv: list[str],
    *,
    name: str = "",
    role: str = "",
    command: list[str] | None = None,
    env: dict[str, str] | None = None,
    line_filter: Callable[[str], str] | None = None,
    on_stderr: Callable[[str], None] | None = None,
    header: str | None = None,
    max_lines: int = LOG_LINES,
) -> Child:
    """Run `COMMAND ARGV…` (COMMAND defaults to `python -m carlaverse`) in a new process group,
    stdin closed, Python's output unbuffered. `line_filter` rewrites every line kept;
    `on_stderr` sees each stderr line as written, before the filter; `header` is `log`'s line 0."""
    full_env = dict(os.environ if env is None else env, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [*(carlaverse_command() if command is None else command), *argv],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=full_env,
        start_new_session=True,  # its own process group: stopped as a whole tree
    )
    label = name or (argv[0] if argv else "child")
    child = Child(label, role, list(argv), proc, LineLog(max_lines), LineLog(max_lines),
                  LineLog(max_lines))  # fmt: skip
    if header is not None:
        child.log.append(header)
    keep = line_filter or (lambda line: line)
    pumps = [
        _Pump(child, proc.stdout, child.out, keep),
        _Pump(child, proc.stderr, child.err, keep, on_stderr),
    ]
    for pump in pumps:
        pump.start()
    follower = threading.Thread(target=_follow, args=(child, pumps), daemon=True)
    follower.start()
    child.readers.extend([*pumps, follower])
    return child


def stop_children(
    children: list[Child], grace_s: float = STOP_GRACE_S, term_grace_s: float = TERM_GRACE_S
) -> None:
    """SIGINT every running child at once; SIGTERM the group of each still running after
    `grace_s`, SIGKILL it and any descendant left `term_grace_s` later. Returns when every
    process of those trees has gone."""
    trees = {id(c): _tree(c.proc.pid) for c in children if c.running}
    running = [c for c in children if id(c) in trees]
    for child in running:
        _signal(child, signal.SIGINT)  # its helpers are its to stop, in order
    _wait_all(running, time.monotonic() + grace_s)
    for child in running:
        if child.running:
            _signal_group(child.proc.pid, signal.SIGTERM)
    _wait_all(running, time.monotonic() + term_grace_s)
    for child in running:
        if child.running:
            _signal_group(child.proc.pid, signal.SIGKILL)
        child.proc.wait()
    deadline = time.monotonic() + term_grace_s
    for child in running:
        _kill_left(trees[id(child)], deadline)


def parse_json(lines: list[str]) -> Any:
    """The first JSON document in `lines` that starts a line with `{` or `[` (a command's
    `--json` output after any lines of its own); None if there is none."""
    decoder = json.JSONDecoder()
    for i, line in enumerate(lines):
        if not line.lstrip().startswith(("{", "[")):
            continue
        try:
            document, _end = decoder.raw_decode("\n".join(lines[i:]).lstrip())
        except json.JSONDecodeError:
            continue
        return document
    return None


def _prefix(prefix: str) -> Callable[[str], bool]:
    return lambda line: line.startswith(prefix)


class _Pump(threading.Thread):
    """Copies one of a child's streams into its logs, line by line, until the stream closes."""

    def __init__(
        self,
        child: Child,
        stream: IO[str] | None,
        own: LineLog,
        keep: Callable[[str], str],
        watch: Callable[[str], None] | None = None,
    ) -> None:
        super().__init__(name=f"log-{child.name}", daemon=True)
        self.child, self.stream, self.own, self.keep, self.watch = child, stream, own, keep, watch

    def run(self) -> None:
        if self.stream is None:
            return
        for raw in self.stream:
            if self.watch is not None:
                self.watch(raw)
            line = self.keep(raw.rstrip("\n"))
            self.own.append(line)
            self.child.log.append(line)


def _follow(child: Child, pumps: list[_Pump]) -> None:
    """Both streams into the log, then the exit code as its last line."""
    for pump in pumps:
        pump.join()
    child.log.append(f"[exited with code {child.proc.wait()}]")


def _wait_all(children: list[Child], deadline: float) -> None:
    for child in children:
        try:
            child.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass


def _signal(child: Child, signum: signal.Signals) -> None:
    try:
        child.proc.send_signal(signum)
    except ProcessLookupError:
        pass  # it has gone already


def _signal_group(pgid: int, signum: signal.Signals) -> None:
    try:
        os.killpg(pgid, signum)
    except (ProcessLookupError, PermissionError):
        pass  # the group has gone already (a reaped leader's id may be reused: not ours)


def _tree(pid: int) -> list[Any]:
    """The process and its descendants now, so those that leave its group are still found.
    Without psutil (not in every extra) only the group is stopped."""
    try:
        import psutil
    except ImportError:
        return []
    try:
        root = psutil.Process(pid)
        return [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return []


def _kill_left(tree: list[Any], deadline: float) -> None:
    """Wait out the grace for descendants still alive, then kill them."""
    if not tree:
        return
    import psutil

    alive = [p for p in tree if _alive(p)]
    _gone, alive = psutil.wait_procs(alive, timeout=max(0.0, deadline - time.monotonic()))
    for process in alive:
        try:
            process.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(alive, timeout=2.0)


def _alive(process: Any) -> bool:
    import psutil

    try:
        return bool(process.is_running() and process.status() != psutil.STATUS_ZOMBIE)
    except psutil.NoSuchProcess:
        return False


class ParentWatch:
    """Whether the process that started this one still lives.

    A parent killed outright (SIGKILL, the OOM killer, a crash in native code) never tells its
    children to stop: a node's control loop, reparented to init, would tick on at 1 kHz for
    ever, holding a core and the devices; a study agent would outlive its runner. A changed
    parent pid is the sign: one syscall, cheap enough for every control poll of a loop."""

    def __init__(self) -> None:
        parent = multiprocessing.parent_process()  # the node, even if it is already gone
        self.pid = parent.pid if parent is not None and parent.pid else os.getppid()

    def gone(self) -> bool:
        return os.getppid() != self.pid
