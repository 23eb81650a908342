"""The README's shell examples as a newcomer runs them (tests/test_newcomer.py): each line
extracted from the README, started in a scratch folder against the README's own session,
waited for until it is ready, stopped, and judged.

How a line is judged: a line ending in `&` runs in the background until the end of the
README (a `wait` line waits for those of its block); a line that runs until stopped (a
router, an authority, a join or record without `--duration`, a viewer that serves) must
still be running once it is ready, then stop cleanly on Ctrl-C (SIGINT, exit 0); any other
line must end by itself with exit 0. No line may print a traceback. A line that needs a
device this machine lacks (a sound card) must say so in its last line and exit 2.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")

READY_S = 120  # [s] a long-running line's wait to be ready (a loaded host is slow to start)
DWELL_S = 5  # [s] a long-running line with nothing to wait for runs this long before Ctrl-C
FINITE_S = 240  # [s] the longest a line that ends by itself may take
STOP_S = 30  # [s] for a clean exit after Ctrl-C
README_ENDPOINT = "tcp/127.0.0.1:7447"
README_HMI_PORT = "8080"
# Lines of the README's shell blocks that install or benchmark: set-up, run by parts 1 and 2
# (the quick start) or by CI itself (the test command), not examples to run against a session.
SETUP = ("pip ", "bash ", "sudo ", "python ")


def shell_blocks(text: str) -> list[list[str]]:
    """The lines of each ```sh block, in order."""
    return [block.strip("\n").splitlines()
            for block in re.findall(r"^```sh\n(.*?)^```", text, re.M | re.S)]  # fmt: skip


def quick_start() -> str:
    setup = README.split("## Set-up: two commands\n", 1)[1].split("\n## ", 1)[0]
    return shell_blocks(setup)[0][0]


@dataclass
class Line:
    """One README example, as the test runs it."""

    text: str  # as written in the README
    argv: list[str]
    background: bool

    @property
    def command(self) -> str:
        return " ".join(self.argv[1:3])

    def option(self, name: str) -> str | None:
        return self.argv[self.argv.index(name) + 1] if name in self.argv else None

    def runs_until_stopped(self) -> bool:
        verb = self.argv[1]
        if verb in ("router", "authority", "launcher"):
            return True
        if verb in ("join", "record"):
            return "--duration" not in self.argv
        if verb == "view":
            return "--serve" in self.argv or "--spawn" in self.argv
        return verb == "replay" and "--loop" in self.argv

    def needs_sound_card(self) -> bool:
        return self.option("--audio") == "audio/headphones"


def example_lines(endpoint: str, hmi_port: int) -> list[list[Line | str]]:
    """Each example block's lines (`wait` kept as the string), with the test's ports."""
    blocks = []
    for block in shell_blocks(README.split("## Command line\n", 1)[1]):
        lines: list[Line | str] = []
        for raw in block:
            text = raw.split("  #", 1)[0].strip()  # a comment is two spaces and a hash away
            if not text or text.startswith(SETUP):
                continue
            if text == "wait":
                lines.append("wait")
                continue
            assert text.startswith("carlaverse "), f"README example the test cannot run: {raw!r}"
            background = text.endswith("&")
            bare = re.sub(r"\s*\[[^\]]*\]", "", text.removesuffix("&"))  # optional parts out
            bare = bare.replace(README_ENDPOINT, endpoint)
            argv = shlex.split(bare)
            if "--hmi" in argv:
                assert argv[argv.index("--hmi") + 1] == README_HMI_PORT, raw
                argv[argv.index("--hmi") + 1] = str(hmi_port)
            lines.append(Line(raw.strip(), argv, background))
        if lines:
            blocks.append(lines)
    return blocks


@dataclass
class Running:
    line: Line
    proc: subprocess.Popen[str]
    log: Path
    started: float = field(default_factory=time.monotonic)

    def output(self) -> str:
        return self.log.read_text(errors="replace")


def start(line: Line, cwd: Path, env: dict[str, str], index: int) -> Running:
    log = cwd / f"line-{index:02d}.log"
    with log.open("w") as out:
        proc = subprocess.Popen(line.argv, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT,
                                text=True, start_new_session=True)  # fmt: skip
    return Running(line, proc, log)


def stop(run: Running) -> int:
    if run.proc.poll() is None:
        os.kill(run.proc.pid, signal.SIGINT)
    try:
        return run.proc.wait(timeout=STOP_S)
    except subprocess.TimeoutExpired:
        os.killpg(run.proc.pid, signal.SIGKILL)
        run.proc.wait()
        return -9


class Watcher:
    """An observer of the README's session: a join is ready once the session sees it."""

    def __init__(self, endpoint: str, session: str) -> None:
        self.endpoint, self.session = endpoint, session
        self.client: Any = None
        self.fabric: Any = None

    def sees(self, node_id: str) -> bool:
        self._open()
        self.client.update()
        return node_id in self.client.world.present

    def admitted(self) -> bool:
        """Whether the session's authority has admitted the watcher: it runs and answers."""
        self._open()
        return bool(self.client.joined.is_set())

    def _open(self) -> None:
        if self.client is None:
            from carlaverse.transport.clock import MonotonicClock
            from carlaverse.transport.node_client import NodeClient, NodeSettings
            from carlaverse.transport.session import FabricSettings, open_session

            self.fabric = open_session(FabricSettings(connect=[self.endpoint]),
                                       deadline=time.monotonic() + 20.0)  # fmt: skip
            settings = NodeSettings(node_id="newcomer-watch", session=self.session,
                                    kind="observer", actor_kind="")  # fmt: skip
            self.client = NodeClient(self.fabric, settings, MonotonicClock()).start()

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.fabric.close()


def wait_ready(run: Running, watcher: Watcher) -> None:
    """Until the line is ready — a router accepting, an authority admitting, a join admitted
    to the session, a viewer's URL printed — or, with nothing to wait for, DWELL_S; it must
    not have ended meanwhile."""
    verb = run.line.argv[1]
    node_id = run.line.option("--id") if verb == "join" else None
    listen = run.line.option("--listen") if verb == "router" else None
    waits = node_id is not None or verb in ("view", "router", "authority")
    deadline = time.monotonic() + (READY_S if waits else DWELL_S)
    while time.monotonic() < deadline:
        if run.proc.poll() is not None and run.line.needs_sound_card():
            return  # it said what it lacks: `judge` reads it
        assert run.proc.poll() is None, f"`{run.line.text}` ended ({run.proc.returncode}) " \
            f"instead of running:\n{run.output()}"  # fmt: skip
        if node_id is not None and run.line.option("--session") == watcher.session \
                and watcher.sees(node_id):  # fmt: skip
            return
        if verb == "view" and "http" in run.output():
            return
        if listen is not None and _answers(int(listen.rpartition(":")[2])):
            return
        if verb == "authority" and run.line.option("--session") == watcher.session \
                and watcher.admitted():  # fmt: skip
            return
        time.sleep(0.2)
    assert not waits, f"`{run.line.text}` never got ready:\n{run.output()}"


def wait_for_the_id_to_be_free(line: Line, earlier: list[Running], watcher: Watcher) -> None:
    """A README line that reuses a node id (car-1 joins again in a later block) runs once the
    earlier holder has ended and left the session, as a person typing it would see it:
    before, the authority would refuse the id as held (or this test take the old holder's
    presence for the new node's)."""
    node_id = line.option("--id") if line.argv[1] == "join" else None
    if node_id is None:
        return
    for run in earlier:
        if run.line.option("--id") == node_id and run.line.argv[1] == "join":
            judge(run, run.proc.wait(timeout=FINITE_S) if not run.line.runs_until_stopped()
                  else stop(run))  # fmt: skip
    if line.option("--session") == watcher.session and watcher.client is not None:
        deadline = time.monotonic() + READY_S
        while watcher.sees(node_id):
            assert time.monotonic() < deadline, f"{node_id} never left the session"
            time.sleep(0.2)


def _answers(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
    except OSError:
        return False
    return True


def judge(run: Running, code: int) -> None:
    said = run.output()
    assert "Traceback" not in said, f"`{run.line.text}` printed a traceback:\n{said}"
    if run.line.needs_sound_card() and code != 0:  # this machine has none
        last = said.strip().splitlines()[-1]
        assert code == 2 and "PortAudio" in last, f"`{run.line.text}`: {code}, {last!r}"
        return
    assert code == 0, f"`{run.line.text}` exited {code}:\n{said}"
