"""The lab's refusals and the presence rows it lists."""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.keys import KeySpaceError
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.lab import Lab
from carlaverse.launcher.presence import presence_rows
from carlaverse.launcher.processes import LaunchError, Supervisor
from carlaverse.world.stream_summary import StreamSummary
from tests.support import wait_until


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


@pytest.mark.parametrize(
    ("port", "bind", "error"),
    [
        (0, "127.0.0.1", "HMI port 0: not a TCP port"),  # 0 (any free port) is not shown back
        (65536, "127.0.0.1", "HMI port 65536: not a TCP port"),
        (True, "127.0.0.1", "HMI port True: not a TCP port"),  # a bool is an int to Python
        ("8080", "127.0.0.1", "HMI port '8080': not a TCP port"),
        (8080, "localhost", "HMI bind address 'localhost': not an IP address"),
        (8080, "0.0.0.0 --hmi-token", "HMI bind address '0.0.0.0 --hmi-token': not an IP"),
        (8080, "", "HMI bind address '': not an IP address"),
    ],
)
def test_lab_refuses_a_bad_hmi_port_or_address(lab: Lab, port: object, bind: str,
                                               error: str) -> None:  # fmt: skip
    with pytest.raises(LaunchError, match=re.escape(error)) as refused:
        lab.start_node("drive", "cab", hmi_port=port, hmi_bind=bind)  # type: ignore[arg-type]
    assert "\n" not in str(refused.value)
    with pytest.raises(LaunchError, match="node kind 'scripted' has no web HMI"):
        lab.start_node("scripted", "n-1", hmi_port=8080)
    assert lab.supervisor.snapshot() == []


# A stand-in for `carlaverse join`: says its argv, prints a pairing line on stderr as the node
# does (for the port it was given after --hmi), and waits to be stopped.
PAIRING_NODE = (
    "import sys, time\n"
    "print(' '.join(sys.argv[1:]), flush=True)\n"
    "port = sys.argv[sys.argv.index('--hmi') + 1] if '--hmi' in sys.argv else '1'\n"
    "sys.stderr.write('carlaverse join: HMI pairing URL (keep it private): '\n"
    "                 f'http://10.0.0.5:{port}/dashboard?token={\"t\" * 43}\\n')\n"
    "sys.stderr.flush()\n"
    "time.sleep(60)\n"
)


def test_a_nodes_pairing_url_is_listed_while_that_very_process_runs(tmp_path: Path) -> None:
    supervisor = Supervisor(command=[sys.executable, "-c", PAIRING_NODE], grace_s=1.0)
    lab = Lab("lab", "tcp/127.0.0.1:1", ConfigDir(tmp_path), supervisor)
    try:
        child = lab.start_node("drive", "cab", hmi_port=8080, hmi_bind="0.0.0.0")
        assert child.argv[-4:] == ["--hmi", "8080", "--hmi-bind", "0.0.0.0"]
        url = f"http://10.0.0.5:8080/dashboard?token={'t' * 43}"
        wait_until(lambda: lab.hmi_pairings() == [("cab", url)], 20, "cab's pairing URL")
        lab.stop("cab")
        assert lab.hmi_pairings() == []  # its HMI went with it
        # the same name again, without an HMI: the line it prints is nobody's pairing URL
        lab.start_node("drive", "cab")
        wait_until(lambda: "pairing" in "".join(lab.supervisor.lines("cab")[1]), 20, "its line")
        assert lab.hmi_pairings() == []
    finally:
        lab.close()
