"""The supervisor: children in their own groups, logs kept, whole trees stopped — even a child
deaf to SIGINT whose own child left its group."""

from __future__ import annotations

import os
import sys
import textwrap

import psutil
import pytest

from carlaverse.launcher.processes import LaunchError, Supervisor
from carlaverse.procs import Child
from tests.support import wait_until

# A stubborn child: ignores SIGINT, starts a grandchild in a session (group) of its own that
# ignores it too, says both pids, and sleeps.
DEAF_TREE = textwrap.dedent(
    """
    import signal, subprocess, sys, time
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    code = "import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(60)"
    grandchild = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    print("pids", grandchild.pid, flush=True)
    time.sleep(60)
    """
)
# A polite child: prints, then exits on SIGINT through KeyboardInterrupt.
POLITE = "import sys, time\nprint('hello from', sys.argv[1], flush=True)\ntime.sleep(60)"


def _python(script: str) -> Supervisor:
    """A supervisor whose `argv` runs `script` instead of `carlaverse` (argv → sys.argv[1:])."""
    return Supervisor(command=[sys.executable, "-c", script], grace_s=1.0)


def _grandchild(child: Child) -> psutil.Process:
    line = wait_until(
        lambda: next((ln for ln in child.log.since(0)[1] if ln.startswith("pids")), None),
        20,
        "the child to report its grandchild",
    )
    return psutil.Process(int(line.split()[1]))


def test_child_runs_in_its_own_group_and_its_log_is_kept() -> None:
    supervisor = _python(POLITE)
    child = supervisor.start("polite", "node", ["polite-1"])
    try:
        wait_until(lambda: "hello from polite-1" in supervisor.lines("polite")[1], 20, "its line")
        assert child.log.since(0)[1][0] == "$ carlaverse polite-1"  # the command, first
        assert os.getpgid(child.proc.pid) == child.proc.pid  # a group of its own
        next_index, lines = supervisor.lines("polite", 1)
        assert next_index == 2 and lines == ["hello from polite-1"]
        assert supervisor.lines("polite", next_index) == (2, [])
    finally:
        supervisor.stop_all()
    assert not child.running
    assert child.exit_code != 0  # KeyboardInterrupt from SIGINT
    wait_until(lambda: supervisor.lines("polite", 0)[1][-1].startswith("[exited"), 5, "exit line")


def test_a_name_runs_once() -> None:
    supervisor = _python(POLITE)
    try:
        supervisor.start("n", "node", ["n"])
        with pytest.raises(LaunchError, match="already running"):
            supervisor.start("n", "node", ["n"])
    finally:
        supervisor.stop_all()


def test_stop_kills_a_deaf_child_and_the_grandchild_that_left_its_group() -> None:
    supervisor = _python(DEAF_TREE)
    child = supervisor.start("deaf", "tool", ["deaf"])
    grandchild = _grandchild(child)
    assert os.getpgid(grandchild.pid) != child.proc.pid  # out of the child's group
    supervisor.stop("deaf")  # SIGINT ignored by both; killed after the 1 s grace
    assert not child.running
    assert not grandchild.is_running() or grandchild.status() == psutil.STATUS_ZOMBIE
