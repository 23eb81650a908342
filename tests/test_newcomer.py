"""The newcomer's path, run as a newcomer runs it (issue 43.9), so the README cannot rot.

1. A clean virtual environment (no site packages of this one) runs the README's quick start
   exactly as written there — `pip install -e '.[demo]' && carlaverse demo` — and the demo
   reports that every node saw every other node.
2. In that same environment, with only the `demo` extra, `carlaverse --help` and every
   command's and sub-command's `--help` print their usage and exit 0: help never needs an extra.
3. Every command line of the README's shell examples is extracted from the README and run, in
   the README's order, in a scratch folder, against the session the README itself starts (its
   router, authority and cars): what a line prints and whether it ends by itself decide how
   it is judged. The only changes made to a line are the ones a test must make: the
   router's port 7447 and the HMI's port 8080 become free ports, and optional parts written
   `[--flag value]` are left out. A README line that this test cannot classify fails it.

Part 1 runs while part 3 does (each starts its own router on a free port, so neither sees the
other's session): both mostly wait, so side by side they cost little more than the longer.

How a line is judged, and how it is run: tests/readme_examples.py.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import venv
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from carlaverse.procs import free_port
from tests.readme_examples import (
    FINITE_S,
    ROOT,
    Line,
    Running,
    Watcher,
    example_lines,
    judge,
    quick_start,
    start,
    stop,
    wait_for_the_id_to_be_free,
    wait_ready,
)

pytestmark = pytest.mark.timeout(900)

QUICK_START_S = 600  # [s] a fresh install from the package index, then the 15 s demo
EXPECTED_QUICK_START = "pip install -e '.[demo]' && carlaverse demo"


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
                wait_for_the_id_to_be_free(line, background + mine, watcher)
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
