"""One recorded demo session for every test that reads a demo's recording (tests/conftest.py
offers it to the whole suite).

`carlaverse demo --duration 8 --json --quiet --record demo.mcap --rrd demo.rrd`, run once per
test session: the recording tests check the MCAP and the RRD against the demo's own summary,
the OSI export reads the same MCAP. Each used to run a demo of its own (8 and 4 s, each with
its router, authority with SUMO and three nodes to start): the files are only read, never
changed, so one run serves both. (The analysis test keeps a demo of its own without a viewer:
it holds interpolated poses to 1 cm of their circle, which a pose gap on a loaded host - more
likely beside the viewer writing the RRD - can exceed; the OSI test bounds its deviation by the
recording's own longest gap.)
"""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

DEMO_S = 8.0  # [s] the longest any of its readers asked for


@dataclass(frozen=True)
class RecordedDemo:
    summary: dict[str, Any]  # what `demo --json` printed
    mcap: Path
    rrd: Path


@pytest.fixture(scope="session")
def recorded_demo(tmp_path_factory: pytest.TempPathFactory) -> RecordedDemo:
    """The demo's recording and summary; read them, never write into their folder."""
    folder = tmp_path_factory.mktemp("recorded-demo")
    mcap, rrd = folder / "demo.mcap", folder / "demo.rrd"
    done = subprocess.run(
        [sys.executable, "-m", "carlaverse", "demo", "--duration", str(DEMO_S), "--json",
         "--quiet", "--record", str(mcap), "--rrd", str(rrd)],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return RecordedDemo(json.loads(done.stdout), mcap, rrd)
