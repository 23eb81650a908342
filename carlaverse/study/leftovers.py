"""Processes a killed runner left behind, found and stopped by the next run.

A runner killed outright (SIGKILL, a crash) cannot stop its children: the router and a
trial's authority run on in process groups of their own. The runner notes each child it
starts (pid and start time) in `OUT/.runner-children.json`; the next run stops those still
alive whose start time matches (a pid reused since by another program is left alone). The
agents it starts end by themselves when their parent goes (`study agent --exit-with-parent`).
"""

from __future__ import annotations

import json
import logging
import os
import signal
from pathlib import Path

log = logging.getLogger(__name__)

CHILDREN_NAME = ".runner-children.json"


class ChildList:
    """The runner's children, on disk as they are started."""

    def __init__(self, out: Path) -> None:
        self.path = out / CHILDREN_NAME
        self._entries: list[dict[str, float]] = []

    def add(self, pid: int) -> None:
        self._entries.append({"pid": pid, "started": _start_time(pid)})
        staging = self.path.with_suffix(".tmp")
        staging.write_text(json.dumps(self._entries))
        os.replace(staging, self.path)

    def clear(self) -> None:
        self._entries.clear()
        self.path.unlink(missing_ok=True)

    def stop_leftovers(self) -> int:
        """Kill the process groups of a previous run's children still alive; how many."""
        try:
            entries = json.loads(self.path.read_text())
        except FileNotFoundError:
            return 0
        except (OSError, ValueError) as exc:
            log.warning("%s unreadable (%s): leftovers of a killed run not stopped", self.path, exc)
            return 0
        stopped = 0
        for entry in entries:
            pid, started = int(entry["pid"]), float(entry["started"])
            if started and _start_time(pid) == started:
                try:
                    os.killpg(pid, signal.SIGKILL)  # each child leads a group of its own
                    stopped += 1
                except (ProcessLookupError, PermissionError):
                    pass
        self.path.unlink(missing_ok=True)
        return stopped


def _start_time(pid: int) -> float:
    """The process's start time in clock ticks since boot (Linux), 0 if unknown or gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
        return float(fields[19])  # field 22 of stat(5), counted after the command name
    except (OSError, IndexError, ValueError):
        return 0.0
