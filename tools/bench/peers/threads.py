"""Where a receiver's CPU goes, thread by thread, read from /proc at the window's two ends.

Linux counts each thread's CPU time in nanoseconds (`/proc/self/task/<tid>/schedstat`, first
field). A thread's group is told by who made it: the main thread (the node loop of the pose
path; elsewhere it only waits); zenoh-python's callback thread, which runs the subscriber's
Python callback (a `threading` thread named `... (pyo3-closure)`); the other threads Python
knows (the node client's control thread); and native threads Python does not know (Zenoh's
runtime: `rx-0`, `net-0`, `tx-0`, `acc-0`, ...; another library's own threads).
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

MAIN = "main thread"
PYTHON = "Python threads"
CALLBACK = "callback thread"
LIBRARY = "library threads"
GROUPS = (MAIN, CALLBACK, LIBRARY, PYTHON)

ThreadTimes = dict[int, tuple[str, int]]  # tid -> (group, CPU time [ns])


def thread_times() -> ThreadTimes:
    """Every thread of this process now: its group and its CPU time [ns]."""
    python = {t.native_id: t.name for t in threading.enumerate()}
    times: ThreadTimes = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            ns = int((task / "schedstat").read_text().split()[0])
        except OSError:  # the thread ended between the listing and the read
            continue
        tid = int(task.name)
        times[tid] = (_group(tid, python.get(tid)), ns)
    return times


def _group(tid: int, python_name: str | None) -> str:
    if tid == os.getpid():
        return MAIN
    if python_name is None:
        return LIBRARY
    return CALLBACK if python_name.endswith(CALLBACK_THREAD) else PYTHON


CALLBACK_THREAD = "(pyo3-closure)"  # how zenoh-python's callback thread is named


def by_group(before: ThreadTimes, after: ThreadTimes) -> dict[str, float]:
    """CPU time [s] of each group between two readings (a thread born between counts whole)."""
    spent = dict.fromkeys(GROUPS, 0.0)
    for tid, (group, ns) in after.items():
        spent[group] += (ns - before.get(tid, (group, 0))[1]) / 1e9
    return spent
