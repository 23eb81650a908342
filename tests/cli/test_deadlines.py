"""Waiting and failing (docs/protocol.md, "Exit codes"): a deadline holds while a session
opens, a join the authority does not answer is asked again and never read as a refusal, a
recorder or observer that reached nothing says so, and a port in use is one line.

Everything runs the real `carlaverse` in a subprocess against real sockets: a TCP listener
whose accept queue is full (a connect to it hangs, as to a host that drops packets), a real
router, and a stand-in authority on its own Zenoh session that holds join queries unanswered.
"""

from __future__ import annotations

import signal
import socket
import subprocess
import threading
import time
from collections.abc import Iterator

import pytest
import zenoh

from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, Keys
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, Proc, free_port

STARTUP_S = 4.0  # [s] an interpreter and Zenoh starting on a loaded two-core host


@pytest.fixture
def blackhole() -> Iterator[str]:
    """An endpoint whose TCP connects hang: listening with a backlog of 0 and never accepting,
    its one queued connection already taken, so the kernel drops every further SYN."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(0)
    filler = socket.create_connection(server.getsockname())
    probe = socket.socket()
    probe.settimeout(0.5)
    try:
        with pytest.raises(TimeoutError):  # the condition the test needs, checked here
            probe.connect(server.getsockname())
        yield f"tcp/127.0.0.1:{server.getsockname()[1]}"
    finally:
        for s in (probe, filler, server):
            s.close()


def _exit_code(proc: Proc, within_s: float) -> tuple[int, float]:
    started = time.monotonic()
    try:
        code = proc.wait(timeout=within_s)
    except subprocess.TimeoutExpired:
        proc.stop(signal.SIGKILL)
        pytest.fail(f"still running after {within_s:.0f} s: {proc.output()[-1500:]}")
    return code, time.monotonic() - started


def _last_line(proc: Proc) -> str:
    for reader in proc.readers:
        reader.join(timeout=5)
    lines = [line.strip() for line in proc.stderr if line.strip()]
    assert lines, proc.output()
    return lines[-1]


def test_join_timeout_holds_while_a_client_waits_on_a_hanging_connect(blackhole: str) -> None:
    """--join-timeout 3 against a router that never answers its TCP connect: exit 5 within
    3 s plus the interpreter's start (the old code retried the open for as long as it ran)."""
    started = time.monotonic()
    node = Proc(["join", "observer", "--id", "o", "--mode", "client", "--connect", blackhole,
                 "--join-timeout", "3"])  # fmt: skip
    code, _ = _exit_code(node, 3 + STARTUP_S + 10)
    took = time.monotonic() - started
    assert code == 5, node.output()
    assert took < 3 + STARTUP_S, f"--join-timeout 3 ended after {took:.1f} s"
    last = _last_line(node)
    assert last.startswith("carlaverse join: o gave up: ") and blackhole in last, last


class SilentAuthority:
    """The authority's liveliness token and join queryable on a session of its own: it holds
    the first `ignore` join queries without a word (as a loaded authority does until the
    node's query times out), then admits."""

    def __init__(self, endpoint: str, session: str, ignore: int) -> None:
        self.keys = Keys(session)
        self.ignore = ignore
        self.asked = 0
        self.held: list[zenoh.Query] = []  # unanswered: dropped, a query would end at once
        self._lock = threading.Lock()
        deadline = time.monotonic() + 20.0
        self.session = open_session(FabricSettings(connect=[endpoint]), deadline=deadline)
        self._queryable = self.session.declare_queryable(self.keys.authority("join"), self._join)
        self._token = self.session.liveliness().declare_token(self.keys.node(AUTHORITY_ID))

    def _join(self, query: zenoh.Query) -> None:
        with self._lock:
            self.asked += 1
            if self.asked <= self.ignore:
                self.held.append(query)
                return
        reply = m.JoinReply(schema=m.SCHEMA_VERSION, accepted=True, session=self.keys.session,
                            authority_instance="silent")  # fmt: skip
        query.reply(query.key_expr, m.JOIN_REPLY.encode(reply))

    def close(self) -> None:
        self._token.undeclare()
        self._queryable.undeclare()
        self.held.clear()
        self.session.close()


@pytest.fixture
def silent_authority(cluster: Cluster) -> Iterator[SilentAuthority]:
    cluster.router()
    authority = SilentAuthority(cluster.endpoint, "t", ignore=10**6)
    try:
        yield authority
    finally:
        authority.close()


def test_an_unanswered_join_is_awaited_and_asked_again_never_refused(
    cluster: Cluster, silent_authority: SilentAuthority
) -> None:
    """Each join query times out after the node's join_timeout_s (2 s): within --join-timeout
    5 the node asks at least twice, says what it waits for, and exits 5, not 4 ("refused:
    Timeout" before)."""
    node = cluster.start("join", "observer", "--id", "walk-2", "--session", "t", "--connect",
                         cluster.endpoint, "--join-timeout", "5", name="walk-2")  # fmt: skip
    code, _ = _exit_code(node, 5 + STARTUP_S + 10)
    assert code == 5, node.output()
    last = _last_line(node)
    assert "refused" not in node.output(), node.output()
    assert last.startswith("carlaverse join: walk-2 gave up: not admitted within --join-timeout")
    assert "to answer the join: no answer within 2 s" in last, last
    assert silent_authority.asked >= 2, silent_authority.asked


def test_a_join_answered_on_the_second_ask_is_admitted(cluster: Cluster) -> None:
    cluster.router()
    authority = SilentAuthority(cluster.endpoint, "t", ignore=1)
    try:
        argv = ["join", "observer", "--id", "walk-2", "--session", "t", "--connect",
                cluster.endpoint, "--duration", "6", "--json"]  # fmt: skip
        node = cluster.start(*argv, name="walk-2")
        code, _ = _exit_code(node, 6 + STARTUP_S + 10)
    finally:
        authority.close()
    assert code == 0, node.output()
    summary = node.json()
    assert summary["joined"] is True and summary["joins"] == 1 and summary["refused"] == ""
    assert authority.asked >= 2


@pytest.mark.parametrize("mode", ["peer", "client"])
@pytest.mark.parametrize("command", ["record", "stats"])
def test_a_recorder_or_observer_that_reached_nothing_says_so_and_exits_3(
    command: str, mode: str, tmp_path
) -> None:
    """Nothing listens at the endpoint for the whole --duration: not "recorded 0 messages" and
    exit 0 (peer) or 5 (client), but one line naming the endpoint and exit 3, fabric error."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    argv = [command, "--session", "t", "--connect", endpoint, "--mode", mode, "--duration", "2"]
    if command == "record":
        argv += ["-o", str(tmp_path / "x.mcap")]
    proc = Proc(argv)
    code, _ = _exit_code(proc, 2 + STARTUP_S + 10)
    assert code == 3, proc.output()
    last = _last_line(proc)
    assert last.startswith(f"carlaverse {command}: ") and endpoint in last, last
    assert "recorded 0 messages" not in proc.output() and "Traceback" not in proc.output()


def test_view_serve_on_a_port_in_use_is_one_line(cluster: Cluster) -> None:
    """rerun's web viewer cannot bind a port another program holds: one line naming the port
    and the flag, exit 2 (a flag to change), no gRPC traceback."""
    cluster.router()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        view = cluster.start("view", "--session", "t", "--connect", cluster.endpoint, "--serve",
                             "--web-port", str(port), "--duration", "30", name="view")  # fmt: skip
        code, _ = _exit_code(view, 30)
    assert code == 2, view.output()
    assert "Traceback" not in view.output() and "gRPC" not in view.output(), view.output()
    assert all(line.startswith("carlaverse view: ") for line in view.stderr if line.strip())
    assert _last_line(view) == (
        f"carlaverse view: --web-port: port {port} on 127.0.0.1 is in use by another program; "
        "choose another, or 0 for any free one"
    )
