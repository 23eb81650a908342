"""`carlaverse demo`, as the README's first command runs it."""

from __future__ import annotations

import json
import subprocess
import sys

import psutil

from tests.support import wait_until


def test_demo_runs_and_every_node_sees_every_other() -> None:
    before = {p.pid for p in psutil.process_iter()}
    done = subprocess.run(
        [sys.executable, "-m", "carlaverse", "demo", "--duration", "20", "--json", "--quiet"],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["all_seen"], json.dumps(summary["nodes"], indent=1)
    nodes = summary["nodes"]
    assert len(nodes) == 3
    for node_id, row in nodes.items():
        assert row["joined"] and row["exit_code"] == 0
        assert set(row["actors_seen"]) == set(nodes) - {node_id}
        assert row["latency_p99_ms"] is not None and row["latency_p99_ms"] < 50
    assert summary["authority"]["tick"]["ticks"] > 20 * 40  # ~50 Hz for 20 s
    # no process is left behind
    leftovers = [
        p
        for p in psutil.process_iter(["cmdline"])
        if p.pid not in before and "carlaverse" in " ".join(p.info["cmdline"] or [])
    ]
    assert not leftovers, [p.info["cmdline"] for p in leftovers]


def test_ctrl_c_stops_everything_cleanly() -> None:
    import signal

    before = {p.pid for p in psutil.process_iter()}
    demo = subprocess.Popen(
        [sys.executable, "-m", "carlaverse", "demo", "--duration", "60", "--scenario", "none"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    me = psutil.Process(demo.pid)
    wait_until(lambda: len(me.children()) >= 5, 30, "router, authority and 3 nodes")
    children = me.children(recursive=True)
    demo.send_signal(signal.SIGINT)
    assert demo.wait(timeout=40) in (0, 1)
    _, alive = psutil.wait_procs(children, timeout=10)
    assert not alive, [p.cmdline() for p in alive]
    leftovers = [
        p
        for p in psutil.process_iter()
        if p.pid not in before and p.pid in {c.pid for c in children}
    ]
    assert not leftovers
