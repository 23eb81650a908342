"""One runner per output folder: two would interleave their trials in one log.

The runner holds an exclusive `flock` on `OUT/.runner.lock` for its whole run; the kernel
drops it when the process ends, however it ends, so a killed runner never leaves a stale
lock behind and the next run resumes at once.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from carlaverse.study.study_log import StudyLogError

LOCK_NAME = ".runner.lock"


class RunLock:
    """Held from `acquire` until `release` or the process's end."""

    def __init__(self, out: Path) -> None:
        self.path = out / LOCK_NAME
        self._fd: int | None = None

    def acquire(self) -> RunLock:
        """StudyLogError naming the holder if another process runs into this folder."""
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise StudyLogError(
                f"{self.path.parent}: another study runner (pid {holder}) runs into this folder; "
                "steer it with `carlaverse study control`, or wait until it ends"
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing drops the lock
            self._fd = None
