"""Where a receiver's CPU goes, thread by thread, read from /proc at the window's two ends.

Linux counts each thread's CPU time in nanoseconds (`/proc/self/task/<tid>/schedstat`, first
field). A thread's group is told by who made it: the main thread (the node loop of the pose
path; elsewhere it only waits); threads Python's `threading` started (the node client's
control thread); native threads that kept the process's own name (zenoh-python's callback
thread, which runs the subscriber's Python callback); and native threads their library named
(Zenoh's runtime: `rx-0`, `net-0`, `tx-0`, `acc-0`, ...).
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
    pid = os.getpid()
    started = {t.native_id for t in threading.enumerate()}
    own_name = Path("/proc/self/comm").read_text().strip()
    times: ThreadTimes = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            ns = int((task / "schedstat").read_text().split()[0])
        except OSError:  # the thread ended between the listing and the read
            continue
        tid = int(task.name)
        if tid == pid:
            group = MAIN
        elif tid in started:
            group = PYTHON
        else:
            group = CALLBACK if name == own_name else LIBRARY
        times[tid] = (group, ns)
    return times


def by_group(before: ThreadTimes, after: ThreadTimes) -> dict[str, float]:
    """CPU time [s] of each group between two readings (a thread born between counts whole)."""
    spent = dict.fromkeys(GROUPS, 0.0)
    for tid, (group, ns) in after.items():
        spent[group] += (ns - before.get(tid, (group, 0))[1]) / 1e9
    return spent
