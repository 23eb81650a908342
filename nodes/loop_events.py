"""The loop side of a node's event queue: take what waits, never wait (the tick must not); and
whether the node that started the loop is still there."""

from __future__ import annotations

import multiprocessing
import os
import queue
from collections.abc import Iterator
from typing import Any


def drain(events: Any) -> Iterator[Any]:
    """Every event waiting on the queue now, without blocking (the loop's tick must not wait)."""
    while True:
        try:
            yield events.get_nowait()
        except queue.Empty:
            return


class ParentWatch:
    """Whether the node process that started this loop still lives.

    A node killed outright (SIGKILL, the OOM killer, a crash in native code) never sets the
    loop's stop event; its loop, reparented to init, would tick on at 1 kHz for ever, holding
    a core and the devices. A changed parent pid is the sign: one syscall, cheap enough for
    every control poll of the loop."""

    def __init__(self) -> None:
        parent = multiprocessing.parent_process()  # the node, even if it is already gone
        self.pid = parent.pid if parent is not None and parent.pid else os.getppid()

    def gone(self) -> bool:
        return os.getppid() != self.pid
