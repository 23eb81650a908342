"""The `--json` outputs docs/protocol.md describes are the ones the commands print."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import msgspec

from carlaverse.authority.service import TickSummary
from carlaverse.node_runtime import NodeSummary
from carlaverse.world.stream_summary import StreamSummary
from tests.support import Cluster

DOC = (Path(__file__).resolve().parents[2] / "docs" / "protocol.md").read_text(encoding="utf-8")


def documented_keys(heading: str, table: int = 0) -> set[str]:
    """The backticked first-column names of the `table`-th table under `### heading`."""
    section = DOC.split(f"### {heading}\n", 1)[1].split("\n#", 1)[0]
    tables = re.findall(r"((?:^\|.*\|\n)+)", section, re.M)
    return set(re.findall(r"^\| `(\w+)` \|", tables[table], re.M))


def fields(cls: type[msgspec.Struct]) -> set[str]:
    return set(cls.__struct_fields__)


def test_authority_join_and_stats_print_what_the_doc_says(cluster: Cluster) -> None:
    cluster.router()
    authority = cluster.authority()
    node = cluster.scripted("car-1", None, "--duration", "6")
    stats = cluster.start("stats", "--session", "t", "--connect", cluster.endpoint,
                          "--duration", "4", "--json", name="stats")  # fmt: skip
    assert node.wait(60) == 0 and stats.wait(60) == 0, node.output() + stats.output()
    authority.stop()

    printed = authority.json()
    assert set(printed) == documented_keys("`carlaverse authority --json`")
    assert set(printed["tick"]) == fields(TickSummary)
    assert ["car-1", "left"] in printed["despawned"]  # it ran out its --duration

    summary = node.json()
    assert set(summary) == fields(NodeSummary)
    observed = stats.json()
    assert set(observed) == documented_keys("`carlaverse stats --json`")
    assert set(observed["nodes"]["car-1"]) == fields(StreamSummary)


def test_demo_prints_what_the_doc_says(tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "carlaverse", "demo", "--duration", "4", "--nodes",
            "scripted,scripted", "--scenario", "none", "--json", "--quiet"]  # fmt: skip
    done = subprocess.run(argv, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout)  # --json: stdout is the document alone
    assert set(summary) == documented_keys("`carlaverse demo --json`")
    rows = summary["nodes"]
    assert set(rows) == {"scripted-1", "scripted-2"}
    assert set(rows["scripted-1"]) == documented_keys("`carlaverse demo --json`", table=1)
    assert summary["ok"] and summary["all_seen"], summary
