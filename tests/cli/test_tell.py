"""A command's notice stays one line while other threads log to the same stderr."""

from __future__ import annotations

import logging
import threading

import pytest

from carlaverse.cli.common import tell


def test_a_notice_is_never_glued_to_a_log_line_from_another_thread(
    capfd: pytest.CaptureFixture[str],
) -> None:
    log = logging.getLogger("test_tell")
    handler = logging.StreamHandler()  # stderr, as the commands' logging is
    log.addHandler(handler)
    log.propagate = False
    done = threading.Event()

    def chatter() -> None:
        while not done.is_set():
            log.warning("a log line from a Zenoh thread")

    talker = threading.Thread(target=chatter)
    talker.start()
    try:
        for k in range(3000):
            tell(f"recording session s{k} into r.mcap")
    finally:
        done.set()
        talker.join()
        log.removeHandler(handler)
    lines = capfd.readouterr().err.splitlines()
    said = [line for line in lines if line.startswith("recording session")]
    assert said == [f"recording session s{k} into r.mcap" for k in range(3000)]
    assert set(lines) - set(said) == {"a log line from a Zenoh thread"}
