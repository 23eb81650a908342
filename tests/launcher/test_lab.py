"""The lab's refusals and the presence rows it lists."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.fabric.stats import StreamSummary
from carlaverse.keys import KeySpaceError
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.lab import Lab
from carlaverse.launcher.presence import presence_rows
from carlaverse.launcher.processes import LaunchError


@pytest.fixture
def lab(tmp_path: Path) -> Iterator[Lab]:
    lab = Lab("lab", "tcp/127.0.0.1:1", ConfigDir(tmp_path))
    yield lab
    lab.close()


def test_lab_refuses_unknown_kinds_and_bad_ids(lab: Lab) -> None:
    with pytest.raises(LaunchError, match="unknown node kind 'scriptd'; did you mean 'scripted'"):
        lab.start_node("scriptd", "n-1")
    with pytest.raises(KeySpaceError):
        lab.start_node("scripted", "bad/id")
    with pytest.raises(LaunchError, match="unknown node kind"):
        lab.start_demo(["scripted", "nope"], 10.0)
    assert lab.supervisor.snapshot() == []  # nothing was started by a refused request


def test_presence_rows_join_stats_and_roster_by_site() -> None:
    summary = StreamSummary(10, 50.0, 1.5, 4.0, 0.3, 0.01, 0.02)
    roster = {
        "car-b": m.EgoInfo("car-b", "drive", "car", m.Extent(), 1500.0, site="berlin"),
        "car-a": m.EgoInfo("car-a", "scripted", "car", m.Extent(), 1500.0, site="zurich"),
    }
    stats = {"car-a": summary, "left": summary}  # `left` published, then went away
    rows = presence_rows({"car-a", "car-b", "new"}, stats, roster)
    assert [(r.node_id, r.site) for r in rows] == [("new", ""), ("car-b", "berlin"),
                                                  ("car-a", "zurich")]  # fmt: skip
    measured = rows[2]
    assert (measured.kind, measured.rate_hz, measured.latency_p99_ms, measured.loss) == (
        "scripted", 50.0, 4.0, 0.01)  # fmt: skip
    assert math.isnan(rows[1].rate_hz)  # present, no pose yet
