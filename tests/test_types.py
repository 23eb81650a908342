"""mypy over the library and the node kinds (issue 41: "mypy clean in CI"), run by pytest,
which is what CI runs. The settings are pyproject.toml's [tool.mypy].

nodes/ installs as `carlaverse_nodes` through a package-dir mapping, which an editable install
serves with an import hook that mypy does not follow; so the test gives mypy a folder holding
a `carlaverse_nodes` link to nodes/ on MYPYPATH. By hand, from the repository root:

    d=$(mktemp -d) && ln -s "$PWD/nodes" "$d/carlaverse_nodes" &&
        MYPYPATH=$d python -m mypy -p carlaverse -p carlaverse_nodes

A cold run over the ~470 files takes about 30 s of CPU (25-85 s on a shared 2-core machine),
so no cache is kept between runs (a stale one could hide an error). Modules that do not import
each other are checked side by side in worker processes (mypy's `--num-workers`, as many as the
cores, up to 4): the same check, over the same files, in about two thirds of the time on two
cores. On one core the workers would only add their start-up: mypy then checks in one process.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHECKED = re.compile(r"in (\d+) source files?")


def workers() -> int:
    """mypy's worker processes: one per core this process may run on, up to 4; 0 (mypy checks
    in-process) on a single core."""
    cores = len(os.sched_getaffinity(0))
    return min(cores, 4) if cores > 1 else 0


def run_mypy(work: Path) -> subprocess.CompletedProcess[str]:
    path = work / "path"
    path.mkdir()
    (path / "carlaverse_nodes").symlink_to(ROOT / "nodes", target_is_directory=True)
    env = {**os.environ, "MYPYPATH": str(path)}
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(work / "cache"),
         "--num-workers", str(workers()), "-p", "carlaverse", "-p", "carlaverse_nodes"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def test_mypy_finds_no_error(tmp_path: Path) -> None:
    done = run_mypy(tmp_path)
    # Errors in nodes/ are reported under the link's path: name them as the tree does.
    report = (done.stdout + done.stderr).replace(
        str(tmp_path / "path" / "carlaverse_nodes"), "nodes"
    )
    assert done.returncode == 0, report
    checked = CHECKED.search(done.stdout)
    # It read the tree, not an empty package list: carlaverse and nodes hold ~430 modules.
    assert checked is not None and int(checked[1]) > 300, report
