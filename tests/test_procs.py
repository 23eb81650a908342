"""carlaverse.procs, the one way children are started, read, waited on and stopped: through
real child processes (Python one-liners), real signals and real pipes."""

from __future__ import annotations

import os
import signal
import socket
import sys
import textwrap
import threading
import time

import pytest

from carlaverse.procs import ChildFailed, LineLog, free_port, parse_json, start, stop_children

PYTHON = [sys.executable, "-c"]


def _script(source: str) -> list[str]:
    return [*PYTHON, textwrap.dedent(source)]


def test_log_keeps_the_newest_lines_and_counts_the_rest() -> None:
    log = LineLog(maxlen=3)
    for i in range(5):
        log.append(f"line {i}")
    # 5 lines numbered 0..4; a log of 3 keeps 2, 3, 4; asking from 0 gets what is kept
    assert log.since(0) == (5, ["line 2", "line 3", "line 4"])
    assert log.since(4) == (5, ["line 4"])
    assert log.since(5) == (5, [])


def test_streams_are_read_apart_and_together_in_a_group_of_its_own() -> None:
    child = start([], command=_script("""
        import sys
        print("to out", flush=True)
        print("to err", file=sys.stderr, flush=True)
        """), name="two")  # fmt: skip
    assert child.wait_for_line("to err", 20) == "to err"
    child.finish_reading()
    assert child.out.lines() == ["to out"]
    assert child.err.lines() == ["to err"]
    assert sorted(child.log.lines()[:2]) == ["to err", "to out"]
    assert child.log.lines()[-1] == "[exited with code 0]"
    assert child.proc.wait() == 0


def test_waiting_for_an_exit_gives_its_code_and_last_line_or_none_while_it_runs() -> None:
    # The one-liner prints a line and exits with 3: both are what wait_exit must hand back.
    done = start([], command=_script("import sys; print('bye', flush=True); sys.exit(3)"))
    assert done.wait_exit(20) == 3
    assert done.out.lines() == ["bye"]  # the readers had the last line by the time it returned
    # A child sleeping 30 s has not exited after 0.2 s: no code, and it is still running.
    asleep = start([], command=_script("import time; time.sleep(30)"))
    try:
        assert asleep.wait_exit(0.2) is None and asleep.running
    finally:
        stop_children([asleep], grace_s=5)


def test_own_process_group() -> None:
    child = start([], command=_script("import time; print('up', flush=True); time.sleep(30)"))
    try:
        child.wait_for_line("up", 20, stream="out")
        # start_new_session: the child leads a group (and session) whose id is its pid
        assert os.getpgid(child.proc.pid) == child.proc.pid
    finally:
        stop_children([child], grace_s=5)


def test_a_filter_rewrites_every_kept_line_but_on_stderr_sees_it_first() -> None:
    seen: list[str] = []
    child = start(
        [],
        command=_script("import sys; print('secret=42', file=sys.stderr)"),
        line_filter=lambda line: line.replace("42", "…"),
        on_stderr=seen.append,
    )
    child.finish_reading()
    assert child.err.lines() == ["secret=…"] and seen == ["secret=42\n"]


def test_waiting_for_a_line_fails_naming_the_child_that_exited_before_it() -> None:
    child = start([], command=_script("""
        import sys
        print("carlaverse x: bad --thing", file=sys.stderr)
        sys.exit(2)
        """), name="authority")  # fmt: skip
    with pytest.raises(ChildFailed, match=r"the authority exited \(2\): carlaverse x: bad"):
        child.wait_for_line("ready", 20)


def test_waiting_for_a_line_has_a_deadline_and_a_stop() -> None:
    child = start([], command=_script("import time; time.sleep(30)"), name="mute")
    try:
        began = time.monotonic()
        with pytest.raises(ChildFailed, match="did not start within"):
            child.wait_for_line("ready", 0.3)
        assert time.monotonic() - began < 5.0  # the deadline, not the child's 30 s
        stop = threading.Event()
        stop.set()
        assert child.wait_for_line("ready", 20, stop=stop) is None
    finally:
        stop_children([child], grace_s=5)


def test_stop_goes_sigint_then_sigterm_then_sigkill() -> None:
    # Each child says "up" once its handlers are set. Python's default SIGINT handler raises
    # KeyboardInterrupt, and an uncaught one ends the interpreter by SIGINT itself (Python
    # >= 3.8: returncode -2); ignoring SIGINT leaves SIGTERM's default, death by signal 15
    # (-15); ignoring both leaves only SIGKILL (-9).
    polite = start([], command=_script("import time; print('up', flush=True); time.sleep(30)"))
    deaf = start([], command=_script("""
        import signal, time
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("up", flush=True)
        time.sleep(30)
        """))  # fmt: skip
    stubborn = start([], command=_script("""
        import signal, time
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        print("up", flush=True)
        time.sleep(30)
        """))  # fmt: skip
    children = [polite, deaf, stubborn]
    for child in children:
        child.wait_for_line("up", 20, stream="out")
    began = time.monotonic()
    stop_children(children, grace_s=0.5, term_grace_s=0.5)
    assert polite.proc.returncode == -signal.SIGINT
    assert deaf.proc.returncode == -signal.SIGTERM
    assert stubborn.proc.returncode == -signal.SIGKILL
    assert time.monotonic() - began < 10.0  # the two graces, not the children's 30 s


def test_json_after_log_lines() -> None:
    # a command's --json document follows whatever it printed first, pretty or on one line
    lines = ["starting {not json", "{", '  "ok": true,', '  "n": 3', "}", "bye"]
    assert parse_json(lines) == {"ok": True, "n": 3}
    assert parse_json(['{"a": [1, 2]}']) == {"a": [1, 2]}
    assert parse_json(["no document here"]) is None


def test_free_port_can_be_bound() -> None:
    port = free_port()
    assert 1024 <= port <= 65535  # the kernel picks from the ephemeral range, never a low port
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))


def test_free_udp_port_can_be_bound() -> None:
    port = free_port(udp=True)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", port))
