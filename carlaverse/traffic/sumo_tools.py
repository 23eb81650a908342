"""Finding and running SUMO's command-line tools (netgenerate, netconvert, polyconvert).

Looked for, in order: `$SUMO_HOME/bin`, the `eclipse-sumo` wheel (`import sumo;
sumo.SUMO_HOME`), then `PATH`. A missing tool is an error that says how to install it.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import logging
import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

log = logging.getLogger(__name__)

INSTALL_HINT = (
    "install SUMO for the authority: pip install 'carlaverse[authority]' "
    "(or: pip install eclipse-sumo libsumo sumolib), or set SUMO_HOME to a SUMO installation"
)
TOOL_TIMEOUT_S = 600.0  # [s] a big OSM import takes minutes, never hours


class SumoMissingError(RuntimeError):
    """A SUMO program or library this needs is not installed."""


class SumoToolError(RuntimeError):
    """A SUMO program ran but failed."""


def sumo_homes() -> list[Path]:
    """SUMO installation directories to search: $SUMO_HOME, then the eclipse-sumo wheel.

    Both are kept: libsumo sets SUMO_HOME to the `sumo-data` package when that is installed,
    which holds SUMO's data files but no programs.
    """
    homes = []
    env = os.environ.get("SUMO_HOME")
    if env and Path(env).is_dir():
        homes.append(Path(env))
    try:
        module = importlib.import_module("sumo")
    except ImportError:
        return homes
    home = getattr(module, "SUMO_HOME", None)
    if home and Path(home).is_dir():
        homes.append(Path(home))
    return homes


def find_tool(name: str) -> Path:
    """The path of a SUMO program such as 'netconvert', or SumoMissingError with the fix."""
    looked: list[str] = []
    for home in sumo_homes():
        for candidate in (home / "bin" / name, home / "bin" / f"{name}.exe"):
            looked.append(str(candidate))
            if candidate.is_file() and os.access(candidate, os.X_OK):
                return candidate
    on_path = shutil.which(name)
    if on_path:
        return Path(on_path)
    looked.append("PATH")
    raise SumoMissingError(
        f"SUMO program {name!r} not found (looked in {', '.join(looked)}); {INSTALL_HINT}"
    )


def run_tool(name: str, args: Sequence[str], cwd: Path | None = None) -> str:
    """Run a SUMO program to completion; its stderr becomes the error when it fails."""
    command = [str(find_tool(name)), *args]
    log.info("running %s", " ".join(command))
    try:
        done = subprocess.run(
            command, cwd=cwd, capture_output=True, text=True, timeout=TOOL_TIMEOUT_S, check=False
        )
    except subprocess.TimeoutExpired as exc:
        raise SumoToolError(f"{name} did not finish within {TOOL_TIMEOUT_S:.0f} s") from exc
    if done.returncode != 0:
        tail = "\n".join((done.stderr or done.stdout).strip().splitlines()[-12:])
        raise SumoToolError(f"{name} failed (exit {done.returncode}):\n{tail}")
    for line in done.stderr.splitlines():
        if line.startswith("Warning"):
            log.debug("%s: %s", name, line)
    return done.stdout


def tool_version(name: str) -> str:
    """What identifies the installed tool, for the network cache key: its path, size and
    modification time (asking `<tool> --version` cost a second at every authority start)."""
    path = find_tool(name)
    stat = path.stat()
    return f"{path}:{stat.st_size}:{stat.st_mtime_ns}"


def import_libsumo():
    """Import libsumo on demand, with the fix in the error when it is missing.

    libsumo prints a pyarrow version notice on import when rerun's pyarrow is installed; it
    is harmless for us (no Arrow API is used), so it goes to the debug log, not stdout.
    """
    captured = io.StringIO()
    try:
        with contextlib.redirect_stdout(captured):
            module = importlib.import_module("libsumo")
    except ImportError as exc:
        raise SumoMissingError(f"the libsumo module is missing ({exc}); {INSTALL_HINT}") from exc
    if captured.getvalue():
        log.debug("libsumo: %s", captured.getvalue().strip())
    return module
