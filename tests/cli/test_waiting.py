"""A node or viewer with no router or no authority says so within 5 s and obeys signals in 2 s.

Real processes, real signals: `python -m carlaverse ...` against a port nobody listens on, or a
live router without an authority. Timings are measured from the process start (the 5 s line)
and from the signal (the 2 s exit), so they include interpreter start-up on a loaded machine.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

from tests.support import Cluster, Proc, free_port, wait_until

LINE_WITHIN_S = 5.0  # [s] the acceptance bound for the first "waiting for ..." line
EXIT_WITHIN_S = 2.0  # [s] the acceptance bound from the signal to the exit


def _line(proc: Proc, text: str, started: float, within: float = LINE_WITHIN_S) -> float:
    """Seconds from `started` until `text` appears on stderr; fails after `within`."""
    proc.wait_for_line(lambda line: text in line, within + 1)
    elapsed = time.monotonic() - started
    assert elapsed < within, f"{text!r} after {elapsed:.2f} s"
    return elapsed


def _exit_after(proc: Proc, sig: int) -> tuple[int, float]:
    sent = time.monotonic()
    proc.proc.send_signal(sig)
    code = proc.wait(timeout=10)
    return code, time.monotonic() - sent


def _dead_endpoint() -> str:
    return f"tcp/127.0.0.1:{free_port()}"  # bound then released: nobody listens there


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("mode", ["client", "peer"])
def test_node_names_the_dead_router_and_obeys_signals(mode: str, sig: int) -> None:
    endpoint = _dead_endpoint()
    started = time.monotonic()
    node = Proc(["join", "observer", "--id", "o", "--connect", endpoint, "--mode", mode])
    try:
        _line(node, f"waiting for a router at {endpoint}", started)
        code, took = _exit_after(node, sig)
    finally:
        node.stop(signal.SIGKILL)
    assert took < EXIT_WITHIN_S, f"{mode} mode took {took:.2f} s to obey {sig!r}"
    assert code == 128 + sig, node.output()
    assert "stopped before it was admitted" in node.output()
    assert "Traceback" not in node.output()


@pytest.mark.parametrize("mode", ["client", "peer"])
def test_node_names_the_missing_authority_then_joins_when_it_comes(
    cluster: Cluster, mode: str
) -> None:
    cluster.router()
    started = time.monotonic()
    node = cluster.start(
        "join", "observer", "--id", "o", "--session", "t", "--connect", cluster.endpoint,
        "--mode", mode, "--json", name="node",
    )  # fmt: skip
    _line(node, f"waiting for the authority of session 't' via {cluster.endpoint}", started)
    authority = cluster.authority()
    admitted = "admitted to session 't' by its authority"
    try:
        wait_until(lambda: admitted in node.output(), 20, "the join")
    except AssertionError as exc:
        raise AssertionError(
            f"{exc}\nnode:\n{node.output()}\nauthority:\n{authority.output()}"
        ) from exc
    code, took = _exit_after(node, signal.SIGINT)
    assert code == 0, node.output()
    assert took < EXIT_WITHIN_S
    assert node.json()["joined"] is True


def test_a_joined_node_says_when_its_authority_goes_and_comes_back(cluster: Cluster) -> None:
    """Mid-session, the node runs on without its authority, and its operator is told: one
    line when the authority goes, one when it is back; and the node joins again."""
    cluster.router()
    first = cluster.authority()
    node = cluster.start(
        "join", "observer", "--id", "o", "--session", "t", "--connect", cluster.endpoint,
        "--json", "-v", name="node",
    )  # fmt: skip
    wait_until(lambda: "(join #1)" in node.output(), 20, "the first join")
    assert first.stop(signal.SIGINT) == 0, first.output()
    gone = f"carlaverse join: waiting for the authority of session 't' via {cluster.endpoint}"
    wait_until(lambda: gone in node.output(), 10, "the line saying it went")
    cluster.authority()
    back = "carlaverse join: reached the router and the authority of session 't'"
    wait_until(lambda: back in node.output(), 20, "the line saying it is back")
    wait_until(lambda: "(join #2)" in node.output(), 20, "the second join")
    code, _ = _exit_after(node, signal.SIGINT)
    assert code == 0, node.output()
    summary = node.json()
    assert summary["joins"] == 2
    # the new authority's messages before the re-join are early, not forged
    assert not [k for k in summary["rejected"] if k.endswith("/not_from_authority")], summary
    said = [line.strip() for line in node.stderr if line.startswith("carlaverse join: ")]
    assert len(said) == 2 and said[0].startswith(gone) and said[1] == back, said


@pytest.mark.parametrize("mode", ["client", "peer"])
def test_duration_bounds_the_run_waiting_included(mode: str) -> None:
    endpoint = _dead_endpoint()
    started = time.monotonic()
    node = Proc(["join", "observer", "--id", "o", "--connect", endpoint, "--mode", mode,
                 "--duration", "3"])  # fmt: skip
    try:
        code = node.wait(timeout=20)
    finally:
        node.stop(signal.SIGKILL)
    took = time.monotonic() - started
    assert code == 5, node.output()
    assert took < 3 + 3.0, f"--duration 3 ended after {took:.1f} s"  # + interpreter start
    errors = [line for line in node.stderr if line.strip()]
    assert errors[-1].startswith("carlaverse join: "), errors
    assert endpoint in errors[-1] and "Traceback" not in node.output()


def test_join_timeout_exits_non_zero_with_a_clear_line(cluster: Cluster) -> None:
    cluster.router()
    node = cluster.start(
        "join", "observer", "--id", "o", "--session", "t", "--connect", cluster.endpoint,
        "--join-timeout", "2", name="node",
    )  # fmt: skip
    assert node.wait(timeout=20) == 5, node.output()
    last = [line for line in node.stderr if line.strip()][-1]
    assert "not admitted within --join-timeout" in last
    assert "authority of session 't'" in last


@pytest.mark.parametrize("mode", ["client", "peer"])
def test_viewer_names_the_dead_router_and_obeys_sigterm(mode: str, tmp_path: Path) -> None:
    endpoint = _dead_endpoint()
    started = time.monotonic()
    view = Proc(["view", "--session", "t", "--connect", endpoint, "--mode", mode,
                 "--save", str(tmp_path / "x.rrd")])  # fmt: skip
    try:
        _line(view, f"carlaverse view: waiting for a router at {endpoint}", started)
        code, took = _exit_after(view, signal.SIGTERM)
    finally:
        view.stop(signal.SIGKILL)
    assert took < EXIT_WITHIN_S, f"view took {took:.2f} s to obey SIGTERM"
    assert code == 128 + signal.SIGTERM, view.output()  # stopped before it reached anyone


def test_viewer_names_the_missing_authority(cluster: Cluster, tmp_path: Path) -> None:
    cluster.router()
    started = time.monotonic()
    view = cluster.start(
        "view", "--session", "t", "--connect", cluster.endpoint, "--save",
        str(tmp_path / "x.rrd"), name="view",
    )  # fmt: skip
    _line(view, "waiting for the authority of session 't'", started)
    # Ctrl-C while Rerun still loads (seconds on a loaded host) stops the view before its
    # work began: 130 by the exit-code table. Once its file is open it is a viewer at work,
    # and a Ctrl-C is its clean end: 0.
    wait_until(lambda: (tmp_path / "x.rrd").exists() or not view.alive(), 120, "the .rrd file")
    code, took = _exit_after(view, signal.SIGINT)
    assert code == 0 and took < EXIT_WITHIN_S, view.output()


def test_stats_in_client_mode_names_the_dead_router_and_obeys_sigint() -> None:
    endpoint = _dead_endpoint()
    started = time.monotonic()
    stats = Proc(["stats", "--connect", endpoint, "--mode", "client", "--duration", "60"])
    try:
        _line(stats, f"waiting for a router at {endpoint}", started)
        code, took = _exit_after(stats, signal.SIGINT)
    finally:
        stats.stop(signal.SIGKILL)
    assert took < EXIT_WITHIN_S and code == 130, stats.output()


@pytest.mark.parametrize("mode", ["client", "peer"])
def test_recorder_names_the_dead_router_and_obeys_sigterm(mode: str, tmp_path: Path) -> None:
    endpoint = _dead_endpoint()
    started = time.monotonic()
    record = Proc(["record", "--session", "t", "--connect", endpoint, "--mode", mode,
                   "-o", str(tmp_path / "x.mcap")])  # fmt: skip
    try:
        _line(record, f"carlaverse record: waiting for a router at {endpoint}", started)
        code, took = _exit_after(record, signal.SIGTERM)
    finally:
        record.stop(signal.SIGKILL)
    assert took < EXIT_WITHIN_S, f"record took {took:.2f} s to obey SIGTERM"
    assert code == 128 + signal.SIGTERM, record.output()  # stopped before it reached anyone
    last = [line for line in record.stderr if line.strip()][-1]
    assert last.startswith("carlaverse record: ") and endpoint in last, last


def test_recorder_names_the_missing_authority(cluster: Cluster, tmp_path: Path) -> None:
    cluster.router()
    started = time.monotonic()
    record = cluster.start(
        "record", "--session", "t", "--connect", cluster.endpoint, "-o",
        str(tmp_path / "x.mcap"), name="record",
    )  # fmt: skip
    _line(record, "waiting for the authority of session 't'", started)
    code, took = _exit_after(record, signal.SIGINT)
    assert code == 0 and took < EXIT_WITHIN_S, record.output()
