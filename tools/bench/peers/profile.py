"""Where the pose path's time goes: py-spy attached to its publisher and a receiver.

One extra run of the pose path with py-spy (`record --format raw`: one line per distinct stack
with its sample count) attached to the publisher (`tx`) and the first receiver (`rx0`) for
the measured window. py-spy samples Python threads while they run (idle ones are left out),
so the counts say which Python code of the path uses the CPU: the Zenoh callback (key parse,
hand-over), the node loop's `update()` (checks, decodes and applies), the control thread,
the publisher's send. With `--native`, frames of the Zenoh binding's Rust code under a Python
frame are named too.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

from peers.transport import find_program

SAMPLE_RATE_HZ = 1000  # [Hz] py-spy samples per second and thread
ROLES = ("tx", "rx0")
# Stages of the pose path by the function a stack passes through, in the order they are
# looked for (the first that matches names the stack).
STAGES = (
    ("_on_pose", "Zenoh pose callback (key parse, hand-over)"),
    ("publish_pose", "NodeClient.publish_pose (encode, put)"),
    ("update", "node loop: world view update (decode, checks, streams)"),
    ("_control_loop", "control thread (clock sync, joins)"),
    ("_send_measured", "bench pacing of the publisher"),
)
FRAME = re.compile(r"^(?P<function>[^ ]+) \((?P<file>[^:)]+)")


def py_spy() -> str | None:
    """py-spy next to this interpreter (a venv's bin) or on PATH."""
    beside = Path(sys.executable).parent / "py-spy"
    return str(beside) if beside.exists() else find_program("py-spy")


class PySpy:
    """py-spy recording chosen processes of one run over its measured window."""

    def __init__(self, seconds: float, native: bool) -> None:
        self._seconds = seconds
        self._native = native
        self._dir = tempfile.TemporaryDirectory(prefix="bench-pyspy-")
        self._procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(self, pids: dict[str, int]) -> None:
        program = py_spy()
        if program is None:
            raise RuntimeError("py-spy not installed (pip install -e '.[bench]')")
        for role in ROLES:
            command = [program, "record", "--pid", str(pids[role]), "--format", "raw",
                       "--rate", str(SAMPLE_RATE_HZ), "--duration", f"{self._seconds:.0f}",
                       "--nonblocking", "--output", str(self._path(role))]  # fmt: skip
            command += ["--native"] if self._native else []
            self._procs[role] = subprocess.Popen(
                command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
            )

    def finish(self) -> None:
        for role, proc in self._procs.items():
            _, err = proc.communicate(timeout=self._seconds + 60)
            if proc.returncode != 0:
                raise RuntimeError(f"py-spy on {role} failed: {err.decode()[-300:]}")

    def stacks(self, role: str) -> Counter[str]:
        counts: Counter[str] = Counter()
        for line in self._path(role).read_text().splitlines():
            stack, _, count = line.rpartition(" ")
            if stack and count.isdigit():
                counts[stack] += int(count)
        return counts

    def _path(self, role: str) -> Path:
        return Path(self._dir.name) / f"{role}.txt"


def frames(stack: str) -> list[tuple[str, str]]:
    """(function, file name) of each frame, outermost first."""
    found = []
    for frame in stack.split(";"):
        match = FRAME.match(frame.strip())
        if match:
            found.append((match["function"], Path(match["file"]).name))
    return found


def stage_shares(stacks: Counter[str]) -> list[tuple[str, float]]:
    """Each stage's share of the sampled CPU, and what matched no stage."""
    total = sum(stacks.values()) or 1
    by_stage: Counter[str] = Counter()
    for stack, count in stacks.items():
        # py-spy names methods with their class (`Inbound._on_pose`): compare the last part
        functions = {f.rpartition(".")[2] for f, _ in frames(stack)}
        stage = next((label for f, label in STAGES if f in functions), "other")
        by_stage[stage] += count
    return [(stage, count / total) for stage, count in by_stage.most_common()]


def hottest(stacks: Counter[str], top: int = 6) -> list[tuple[str, float]]:
    """The innermost frames (self time) that took the most samples, with their share."""
    total = sum(stacks.values()) or 1
    leaves: Counter[str] = Counter()
    for stack, count in stacks.items():
        chain = frames(stack)
        if chain:
            leaves[f"{chain[-1][0]} ({chain[-1][1]})"] += count
    return [(leaf, count / total) for leaf, count in leaves.most_common(top)]


def profile_lines(spy: PySpy, seconds: float) -> list[str]:
    """The profile as Markdown lines for the benchmark's section."""
    lines = []
    for role in ROLES:
        stacks = spy.stacks(role)
        samples = sum(stacks.values())
        busy = samples / (SAMPLE_RATE_HZ * seconds)
        name = "publisher" if role == "tx" else "receiver rx0"
        lines.append(
            f"- {name}: {samples} samples, Python threads running {100 * busy:.1f} % of one "
            "core; by stage: "
            + "; ".join(f"{stage} {100 * share:.0f} %" for stage, share in stage_shares(stacks))
            + ". Hottest frames (self): "
            + "; ".join(f"`{leaf}` {100 * share:.0f} %" for leaf, share in hottest(stacks))
            + "."
        )
    return lines
