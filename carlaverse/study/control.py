"""Steering a running study from outside: one command at a time through a control file.

`carlaverse study control OUT pause|resume|abort|redo|note TEXT` writes the command to a file
of its own, `OUT/control-<time>-<pid>.cmd` (written, then renamed, so the runner never reads
half a command, and two commands sent at once are both kept); the runner takes the oldest
(reads, then deletes) at its next look, a few times a second:

- pause: finish the current trial, then start no next one until `resume`;
- resume: go on after a pause;
- abort: end the current trial now (outcome `aborted`), log it, and stop the run; a later
  run resumes with that trial;
- redo: end the current trial now (outcome `redo`) and run it again at once;
- note TEXT: a note in the study log, with the current trial.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

CONTROL_PREFIX, CONTROL_SUFFIX = "control-", ".cmd"
COMMANDS = ("pause", "resume", "abort", "redo", "note")


@dataclass(frozen=True)
class Command:
    name: str  # one of COMMANDS
    text: str = ""  # a note's text


def parse_command(line: str) -> Command:
    """A command from its line; ValueError naming the commands for anything else."""
    name, _, text = line.strip().partition(" ")
    if name not in COMMANDS:
        raise ValueError(f"unknown study command {name!r}: expected one of {', '.join(COMMANDS)}")
    if name == "note" and not text.strip():
        raise ValueError("note needs its text: note TEXT")
    if name != "note" and text:
        raise ValueError(f"{name} takes no text")
    return Command(name, text.strip())


def send(out: Path, line: str) -> Command:
    """Hand `line` to the runner writing into `out`; ValueError for a bad command."""
    command = parse_command(line)
    if not out.is_dir():
        raise ValueError(f"{out}: no such study output folder")
    name = f"{CONTROL_PREFIX}{time.time_ns():020d}-{os.getpid()}{CONTROL_SUFFIX}"
    staging = out / f".{name}"
    staging.write_text(line.strip() + "\n")
    os.replace(staging, out / name)
    return command


def pending(out: Path) -> list[Path]:
    """The commands waiting in `out`, oldest first."""
    return sorted(out.glob(f"{CONTROL_PREFIX}*{CONTROL_SUFFIX}"))


def take(out: Path) -> Command | None:
    """The oldest command waiting in `out`, taken (its file removed); None if there is none.
    A bad command comes back as a note saying so, so it is seen in the log and not lost."""
    for path in pending(out):
        try:
            line = path.read_text()
            path.unlink()
        except FileNotFoundError:
            continue  # taken by another reader meanwhile
        try:
            return parse_command(line)
        except ValueError as exc:
            return Command("note", f"ignored control command: {exc}")
    return None
