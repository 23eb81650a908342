"""The one exit-code table of every `carlaverse` command, and the parser that keeps to it.

A script that runs `carlaverse join`, `record` or `render` tells from the code alone whether
to fix its arguments (2), look at the network (3), change the node's id (4) or wait longer
(5). docs/protocol.md ("Exit codes") is generated from `MEANING`; a command that ends for any
of these reasons returns the member, never a bare number. Nothing here imports Zenoh, so the
dispatcher may use it before it knows which command runs.
"""

from __future__ import annotations

import argparse
import signal
from enum import IntEnum
from typing import NoReturn


class Exit(IntEnum):
    """How a command ended."""

    OK = 0
    FAILED = 1
    USAGE = 2
    FABRIC = 3
    REFUSED = 4
    NOT_ADMITTED = 5
    SIGINT = 128 + signal.SIGINT  # 130
    SIGTERM = 128 + signal.SIGTERM  # 143

    @classmethod
    def stopped_by(cls, signum: int) -> Exit:
        """The code of a command a signal stopped before its work began (128 + N)."""
        return cls(128 + signum)


MEANING: dict[Exit, str] = {
    Exit.OK: "done",
    Exit.FAILED: "the command ran and its work failed: a recording that could not be "
    "written, a render with nothing to show, a photograph with nobody in it, the traffic "
    "engine stopped",
    Exit.USAGE: "usage or input error, nothing started: a bad flag or value, a config that "
    "does not decode (broken YAML is `FILE:LINE:COL: problem`), a missing input file, a port "
    "already in use, a missing extra (the line names the `pip install`)",
    Exit.FABRIC: "fabric error: Zenoh refuses an endpoint or setting, the session cannot be "
    "opened, or a recorder or observer (`record`, `stats`, `view`) reached no router or peer "
    "before its `--duration` ran out",
    Exit.REFUSED: "the authority refused the node (a duplicate id, a schema mismatch)",
    Exit.NOT_ADMITTED: "not admitted in time: a node (or the authority, a swarm, a live "
    "render) found no router, or no authority admitted it, before `--join-timeout` or "
    "`--duration` ran out",
    Exit.SIGINT: "stopped by SIGINT (Ctrl-C) before its work began (a node not yet admitted, "
    "a recorder or viewer that had reached no router or peer); a command that runs until "
    "stopped, once at work, ends 0",
    Exit.SIGTERM: "stopped by SIGTERM, as for SIGINT",
}


def summary() -> str:
    """The table in one sentence, for `carlaverse --help`."""
    codes = ", ".join(f"{int(code)} {code.name.lower().replace('_', ' ')}" for code in Exit)
    return f"Exit codes, the same for every command: {codes} (docs/protocol.md, Exit codes)."


class CliParser(argparse.ArgumentParser):
    """argparse, with a usage error said in one line (argparse prints the whole usage block
    first, which buries the line that says what is wrong) and the table's exit code."""

    def error(self, message: str) -> NoReturn:
        self.exit(Exit.USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")
