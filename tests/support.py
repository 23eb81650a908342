"""Shared test plumbing: real processes, real sessions, waiting on conditions with deadlines."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from carlaverse import procs
from carlaverse.authority.domain import EmptyDomain
from carlaverse.authority.service import Authority, AuthoritySettings
from carlaverse.procs import free_port
from carlaverse.transport.clock import MonotonicClock, WallAlignedClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session


def demo_seen(kind: str, *args: str, timeout: float = 120) -> dict[str, Any]:
    """`carlaverse demo --nodes KIND,scripted ARGS --json` run to its end: its summary, once
    it exited 0, every node saw every other and the scripted node saw `KIND-1`."""
    argv = [sys.executable, "-m", "carlaverse", "demo", "--nodes", f"{kind},scripted",
            "--json", "--quiet", *args]  # fmt: skip
    done = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["all_seen"], summary["nodes"]
    assert f"{kind}-1" in summary["nodes"]["scripted-2"]["actors_seen"], summary["nodes"]
    return summary


@contextmanager
def linked_peers() -> Iterator[tuple[Any, Any]]:
    """Two Zenoh peer sessions over loopback: one listening, one connected to it (closed in
    reverse on exit). Patient, as a loaded host may take seconds to open them."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    deadline = time.monotonic() + 20
    listener = open_session(FabricSettings(listen=[endpoint]), deadline=deadline)
    connected = open_session(FabricSettings(connect=[endpoint]), deadline=deadline)
    try:
        yield listener, connected
    finally:
        connected.close()
        listener.close()


def wait_until(condition: Callable[[], Any], timeout: float, what: str, poll: float = 0.02) -> Any:
    """Poll `condition` until it is truthy; fail naming `what` when the deadline passes."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:.1f} s waiting for {what}")
        threading.Event().wait(poll)


class StallWatch:
    """Notices this process stalling, so a test that judges how remote actors are drawn can
    tell what a stall got wrong from what the code under test did.

    On a loaded two-core CI host the test process can stall for hundreds of ms. Its Zenoh
    threads stall too: the samples sent meanwhile arrive all at once after it, the frames
    drawn just then dead-reckon or hold, and the correction the late samples reveal decays
    with the view's `blend_time_s` (0.1 s). A loop that asks for short steps calls `step()`
    once per step; a step longer than `stalled_s` is a stall, and for `settle_s` after it
    `step()` returns the stall's length (0.0 otherwise): frames drawn then are excused the
    test's bound and held to the way an actor drives in the stall, plus that bound."""

    def __init__(self, stalled_s: float = 0.1, settle_s: float = 0.5) -> None:
        self.stalled_s = stalled_s
        self.settle_s = settle_s
        self.stalls: list[float] = []  # [s] each stall's length
        self._last = time.monotonic()
        self._until = self._last
        self._gap = 0.0

    def step(self) -> float:
        now = time.monotonic()
        gap, self._last = now - self._last, now
        if gap > self.stalled_s:
            self.stalls.append(gap)
            self._until, self._gap = now + self.settle_s, max(gap, self._gap)
        elif now >= self._until:
            self._gap = 0.0
        return self._gap


class Proc:
    """A `python -m carlaverse ...` child (`carlaverse.procs`) with its output captured."""

    MAX_LINES = 20000  # per stream: a test reads what a child said, however chatty

    def __init__(self, args: list[str], name: str = "") -> None:
        self.args = args
        self.name = name or args[0]
        self.child = procs.start(args, name=self.name, max_lines=self.MAX_LINES)
        self.proc = self.child.proc
        self.readers = self.child.readers

    @property
    def stdout(self) -> list[str]:
        """Its stdout lines so far, each with its newline."""
        return [line + "\n" for line in self.child.out.lines()]

    @property
    def stderr(self) -> list[str]:
        """Its stderr lines so far, each with its newline."""
        return [line + "\n" for line in self.child.err.lines()]

    def alive(self) -> bool:
        return self.child.running

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15) -> int:
        """Send `sig` and wait up to `timeout` for it to exit; then stop its group for sure."""
        if sig == signal.SIGINT:
            return self.child.stop(timeout)  # SIGINT, SIGTERM, SIGKILL (procs.stop_children)
        if self.alive():
            self.proc.send_signal(sig)
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return self.child.stop(0.0)

    def wait(self, timeout: float) -> int:
        return self.proc.wait(timeout=timeout)

    def wait_for_line(
        self, match: str | Callable[[str], bool], timeout: float, stream: str = "err"
    ) -> str:
        """Its first `stream` line that starts with `match` (or that `match` accepts); fails
        naming it if it exits first or `timeout` passes (`procs.Child.wait_for_line`)."""
        line = self.child.wait_for_line(match, timeout, stream)
        assert line is not None
        return line

    def json(self) -> dict[str, Any]:
        wait_until(lambda: not self.alive(), 1, f"{self.name} to exit")
        document = self.child.json()
        assert isinstance(document, dict), (
            f"{self.name} printed no JSON; stderr:\n{''.join(self.stderr)[-2000:]}"
        )
        return document

    def output(self) -> str:
        return "".join(self.stdout) + "".join(self.stderr)


def _accepts(port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(0.5)
        return probe.connect_ex(("127.0.0.1", port)) == 0


class Cluster:
    """Processes started by one test, all stopped at teardown."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.procs: list[Proc] = []
        self.port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.sessions: list[Any] = []
        self.authorities: list[InProcessAuthority] = []  # stopped first at teardown

    def start(self, *args: str, name: str = "") -> Proc:
        proc = Proc(list(args), name)
        self.procs.append(proc)
        return proc

    def router(self) -> Proc:
        """A router, returned once it accepts connections: a client that tries once (a raw
        zenoh session, a foreign client) would time out against one still starting up."""
        proc = self.start("router", "--listen", self.endpoint, name="router")
        wait_until(lambda: _accepts(self.port) or not proc.alive(), 30, "the router to listen")
        assert proc.alive(), f"the router exited: {proc.output()[-2000:]}"
        return proc

    def authority(self, *extra: str) -> Proc:
        return self.start(
            "authority",
            "--scenario",
            "none",
            "--session",
            "t",
            "--connect",
            self.endpoint,
            "--json",
            *extra,
            name="authority",
        )

    def scripted(self, node_id: str, config: Path | None = None, *extra: str) -> Proc:
        args = [
            "join",
            "scripted",
            "--id",
            node_id,
            "--session",
            "t",
            "--connect",
            self.endpoint,
            "--json",
            *extra,
        ]
        if config is not None:
            args += ["--config", str(config)]
        return self.start(*args, name=node_id)

    def observer(self, node_id: str = "obs", **fabric: Any) -> NodeClient:
        settings = FabricSettings(connect=[self.endpoint], **fabric)
        # Patient like the CLI: a client's one attempt can time out on a loaded host.
        session = open_session(settings, deadline=time.monotonic() + 20.0)
        self.sessions.append(session)
        node = NodeSettings(node_id=node_id, session="t", kind="observer", actor_kind="")
        client = NodeClient(session, node, MonotonicClock()).start()
        self.sessions.append(client)
        return client

    def in_process_authority(self, despawn_timeout_s: float = 3.0) -> InProcessAuthority:
        """An `InProcessAuthority` on this cluster's router, stopped at teardown whatever the
        test did: a live one keeps Zenoh's callback threads, and with them pytest, running."""
        authority = InProcessAuthority(self.endpoint, despawn_timeout_s)
        self.authorities.append(authority)
        return authority

    def close(self) -> None:
        for authority in self.authorities:
            authority.stop()
        for item in reversed(self.sessions):
            item.close()
        for proc in self.procs:
            proc.stop(signal.SIGKILL if not proc.alive() else signal.SIGINT)


class InProcessAuthority:
    """An authority (membership only) on its own session in this process: tests that must
    speak as the authority (impulses, world messages) use its `outbox`. Restartable."""

    def __init__(self, endpoint: str, despawn_timeout_s: float = 3.0) -> None:
        self.endpoint = endpoint
        self.despawn_timeout_s = despawn_timeout_s
        self.authority: Authority | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> Authority:
        settings = AuthoritySettings(session="t", despawn_timeout_s=self.despawn_timeout_s)
        session = open_session(FabricSettings(connect=[self.endpoint]))
        self.authority = Authority(session, settings, WallAlignedClock(), EmptyDomain()).start()
        self._thread = threading.Thread(target=self.authority.run, daemon=True)
        self._thread.start()
        return self.authority

    def stop(self) -> None:
        if self.authority is None or self._thread is None:
            return
        self.authority.close()
        self._thread.join(5)
        self.authority.session.close()
        self.authority = None
