"""The newcomer's path, run as a newcomer runs it (issue 43.9), so the README cannot rot.

1. A clean virtual environment (no site packages of this one) runs the README's quick start
   exactly as written there — `pip install -e '.[demo]' && carlaverse demo` — and the demo
   reports that every node saw every other node.
2. In that same environment, with only the `demo` extra, `carlaverse --help` and every
   command's and sub-command's `--help` print their usage and exit 0: help never needs an extra.
3. Every command line of the README's shell examples is extracted from the README and run, in
   the README's order, in a scratch folder, against the session the README itself starts (its
   router, authority and cars): what a line prints and whether it ends by itself decide how
   it is judged (below). The only changes made to a line are the ones a test must make: the
   router's port 7447 and the HMI's port 8080 become free ports, and optional parts written
   `[--flag value]` are left out. A README line that this test cannot classify fails it.

Part 1 runs while part 3 does (each starts its own router on a free port, so neither sees the
other's session): both mostly wait, so side by side they cost little more than the longer.

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
import shutil
import signal
import socket
import subprocess
import sys
import time
import venv
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from carlaverse.procs import free_port

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
pytestmark = pytest.mark.timeout(900)

QUICK_START_S = 600  # [s] a fresh install from the package index, then the 15 s demo
EXPECTED_QUICK_START = "pip install -e '.[demo]' && carlaverse demo"
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


def _wait_for_the_id_to_be_free(line: Line, earlier: list[Running], watcher: Watcher) -> None:
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


@pytest.fixture
def scratch(tmp_path: Path) -> Iterator[Path]:
    """The newcomer's working folder: the photo `body angles` is shown (matplotlib's)."""
    matplotlib = pytest.importorskip("matplotlib")
    shutil.copy(Path(matplotlib.get_data_path(), "sample_data", "grace_hopper.jpg"),
                tmp_path / "photo.jpg")  # fmt: skip
    yield tmp_path


def test_every_readme_example_runs_against_the_readmes_session(
    quick_start_run: QuickStart, scratch: Path
) -> None:
    """(`quick_start_run`: the quick start runs meanwhile, for its own test to judge.)"""
    pytest.importorskip("mediapipe", reason="`body` examples need mediapipe (install-test-deps)")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    blocks = example_lines(endpoint, free_port())
    assert sum(len(b) for b in blocks) >= 18, "the README lost its examples?"
    env = dict(os.environ)
    watcher = Watcher(endpoint, "lab")  # the README's session
    background: list[Running] = []
    started: list[Running] = []  # every process, killed at the end if one is left
    index = 0
    try:
        for block in blocks:
            mine: list[Running] = []
            for line in block:
                if line == "wait":
                    for run in mine:
                        judge(run, run.proc.wait(timeout=FINITE_S))
                    continue
                assert isinstance(line, Line)
                index += 1
                _wait_for_the_id_to_be_free(line, background + mine, watcher)
                run = start(line, scratch, env, index)
                started.append(run)
                if line.background:
                    mine.append(run)
                    if line.runs_until_stopped():
                        wait_ready(run, watcher)
                elif line.runs_until_stopped():
                    wait_ready(run, watcher)
                    judge(run, stop(run))
                else:
                    try:
                        code = run.proc.wait(timeout=FINITE_S)
                    except subprocess.TimeoutExpired:
                        code = stop(run)
                        pytest.fail(f"`{line.text}` did not end in {FINITE_S} s:\n{run.output()}")
                    judge(run, code)
            background += mine
        for run in reversed(background):  # the session's router stops last
            judge(run, stop(run) if run.line.runs_until_stopped() else run.proc.wait(FINITE_S))
    finally:
        watcher.close()
        for run in started:
            if run.proc.poll() is None:
                os.killpg(run.proc.pid, signal.SIGKILL)
                run.proc.wait()
    made = {p.name for p in scratch.iterdir()}
    assert {"lab.mcap", "lab.rrd", "demo.mcap", "demo.rrd", "demo-analysis",
            "car.wav"} <= made, sorted(made)  # fmt: skip


@pytest.fixture(scope="module")
def clean_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A virtual environment that sees none of this one's packages."""
    where = tmp_path_factory.mktemp("newcomer") / "venv"
    venv.EnvBuilder(with_pip=True, system_site_packages=False).create(where)
    return where


def _in_venv(env_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["PATH"] = f"{env_dir / 'bin'}{os.pathsep}{env['PATH']}"
    env["VIRTUAL_ENV"] = str(env_dir)
    return env


@dataclass
class QuickStart:
    """The README's quick start running in the clean venv, its output going to files."""

    command: str
    proc: subprocess.Popen[bytes] | None  # None: the README's command is not the expected one
    out: Path
    err: Path

    def finish(self) -> tuple[int, str, str]:
        """Its exit code, stdout and stderr, once it has ended (killed past QUICK_START_S)."""
        assert self.proc is not None
        try:
            code = self.proc.wait(timeout=QUICK_START_S)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            code = self.proc.wait()
        return code, self.out.read_text(errors="replace"), self.err.read_text(errors="replace")


@pytest.fixture(scope="module")
def quick_start_run(clean_venv: Path) -> Iterator[QuickStart]:
    """The quick start, started at once and left to run while the README's examples run.

    Both mostly wait - the install on reading ~500 MB of wheels, the demo and the examples on
    their durations (~40 s of the examples' ~60 s) - so side by side they take little more
    than the longer of the two, where one after the other took their sum. Each has its own
    router on a free port and multicast scouting is off: neither can see the other's
    session. Its own test waits for it and judges it; whatever is left at the module's end is
    killed."""
    command = quick_start()
    folder = clean_venv.parent
    run = QuickStart(command, None, folder / "quick-start.out", folder / "quick-start.err")
    if command == EXPECTED_QUICK_START:  # its test says so when the README changed it
        with run.out.open("wb") as out, run.err.open("wb") as err:
            run.proc = subprocess.Popen(["bash", "-c", command], cwd=ROOT,
                                        env=_in_venv(clean_venv), stdout=out, stderr=err,
                                        start_new_session=True)  # fmt: skip
    yield run
    if run.proc is not None and run.proc.poll() is None:
        os.killpg(run.proc.pid, signal.SIGKILL)
        run.proc.wait()


def test_the_quick_start_runs_in_a_clean_venv(quick_start_run: QuickStart) -> None:
    command = quick_start_run.command
    assert command == EXPECTED_QUICK_START, command  # what README says
    code, stdout, stderr = quick_start_run.finish()
    said = stdout + stderr
    assert code == 0, said[-4000:]
    assert "every node saw every other node" in stdout, said[-4000:]
    assert "Traceback" not in said, said[-4000:]


HELP_SCRIPT = """
import argparse, contextlib, io, json, sys
from carlaverse.cli import COMMANDS, _command_parser, build_parser
def helped(argv, parser):
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        try:
            parser.parse_args(argv)
            code = None
        except SystemExit as e:
            code = e.code
    return {"argv": argv, "code": code, "text": out.getvalue()}
results = [helped(["--help"], build_parser())]
for name in COMMANDS:
    parser, _ = _command_parser(name)
    results.append(helped([name, "--help"], build_parser()) | helped(["--help"], parser)
                   | {"argv": [name, "--help"]})
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, subparser in action.choices.items():
                results.append(helped(["--help"], subparser) | {"argv": [name, sub, "--help"]})
print(json.dumps(results))
"""


def test_every_help_works_with_the_demo_extra_alone(
    clean_venv: Path, quick_start_run: QuickStart
) -> None:
    """Needs the quick start's install (the test above, same venv): it waits for the quick
    start to end; if that did not install, it installs."""
    if quick_start_run.proc is not None:
        quick_start_run.finish()
    python = clean_venv / "bin" / "python"
    if not (clean_venv / "bin" / "carlaverse").exists():
        subprocess.run([str(python), "-m", "pip", "install", "-q", "-e", ".[demo]"], cwd=ROOT,
                       env=_in_venv(clean_venv), check=True, timeout=QUICK_START_S)  # fmt: skip
    import json

    # From elsewhere than the checkout: `carlaverse` is imported as installed, not from cwd.
    done = subprocess.run([str(python), "-c", HELP_SCRIPT], cwd=clean_venv,
                          env=_in_venv(clean_venv), capture_output=True, text=True,
                          timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr[-4000:]
    results = json.loads(done.stdout)
    from carlaverse.cli import COMMANDS

    assert len(results) > len(COMMANDS)  # the top level, every command, their actions
    for r in results:
        shown = " ".join(["carlaverse", *r["argv"]])
        assert r["code"] == 0, f"`{shown}` exited {r['code']}:\n{r['text']}"
        assert r["text"].startswith("usage: carlaverse"), f"`{shown}`:\n{r['text'][:500]}"
        assert "Traceback" not in r["text"], f"`{shown}`:\n{r['text']}"


def test_the_examples_cover_every_block_and_are_classified() -> None:
    """Quick and offline: every shell line after the set-up is an example this file can run
    (a `carlaverse` line or `wait`) or a set-up line, and the examples reach a session."""
    blocks = example_lines("tcp/127.0.0.1:1", 1)
    commands = {line.argv[1] for b in blocks for line in b if isinstance(line, Line)}
    assert {"router", "authority", "join", "record", "replay", "view", "analyze"} <= commands
    first = [line for line in blocks[0] if isinstance(line, Line)]
    assert [line.argv[1] for line in first[:2]] == ["router", "authority"], (
        "the README's first example block must start the session the others use"
    )
    assert sys.version_info >= (3, 11)
