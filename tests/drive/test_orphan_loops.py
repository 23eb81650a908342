"""A node killed outright takes its control loop with it (drive, bike and walk alike).

SIGKILL gives a node no chance to set its loop's stop event; before the loops watched their
parent, each one, reparented to init, ticked on at its full rate for ever (one was found
holding half a core 10 minutes after a test had killed its node). The loop polls its
control block every few ticks (tens of milliseconds), so within a few seconds of the kill
nothing of the node may be left."""

from __future__ import annotations

import signal

import psutil

from tests.support import Cluster, wait_until

KINDS = ("drive", "bike", "walk")
GONE_S = 5.0  # [s] well above a control poll (≤ 0.1 s), for a loaded 2-core host


def _loop_children(pid: int) -> list[psutil.Process]:
    """The node's spawned children that run its code (its control loop; a view or audio
    process would be one too), not multiprocessing's resource tracker."""
    try:
        children = psutil.Process(pid).children(recursive=False)
        return [c for c in children if "spawn_main" in " ".join(c.cmdline())]
    except psutil.NoSuchProcess:
        return []


def _start(cluster: Cluster) -> dict[str, psutil.Process]:
    """A node of each kind, each with its loop running: the loops by kind."""
    fabric = ("--session", "t", "--connect", cluster.endpoint, "--backend", "sim")
    nodes = {kind: cluster.start("join", kind, "--id", f"orphan-{kind}", *fabric, name=kind)
             for kind in KINDS}  # fmt: skip
    loops = {}
    for kind, node in nodes.items():
        found = wait_until(lambda n=node: _loop_children(n.proc.pid) or not n.alive(), 120,
                           f"the {kind} loop")  # fmt: skip
        assert node.alive(), f"the {kind} node ended: {node.output()[-2000:]}"
        loops[kind] = found[0]
        loops[kind].node = node  # type: ignore[attr-defined]
    return loops


def test_a_killed_node_leaves_no_loop_running_and_starts_again(cluster: Cluster) -> None:
    cluster.router()
    cluster.authority()
    loops = _start(cluster)
    for loop in loops.values():
        loop.node.proc.send_signal(signal.SIGKILL)  # type: ignore[attr-defined]
    late = []
    for kind, loop in loops.items():
        try:
            loop.wait(timeout=GONE_S)
        except psutil.TimeoutExpired:
            late.append(kind)
            loop.kill()  # not left behind by this test either
    assert not late, f"these loops ran on {GONE_S} s past their killed node: {late}"
    # Started again under the same ids, whatever the killed ones left in /dev/shm: each
    # gets its loop (a block left behind is reclaimed, carlaverse.shm).
    again = _start(cluster)
    assert set(again) == set(KINDS)
