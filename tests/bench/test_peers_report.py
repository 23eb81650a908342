"""The peers benchmark's arithmetic (tools/bench/peers/report.py) on runs made by hand.

Pooling must count every measured receiver of every round, divide CPU by the right number of
poses, and judge issue 41's targets (pose path p50 <= 1.2 x bare Zenoh's p50, its receivers'
CPU per pose <= 1.5 x bare Zenoh's) both ways, pooled and round by round.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[2] / "tools" / "bench"


@pytest.fixture
def report(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    monkeypatch.syspath_prepend(str(BENCH))  # the harness imports itself as `peers`
    import peers.report

    return peers.report


def run(name: str, latencies_ms: list[list[float]], cpu_s: dict[str, float]) -> dict[str, Any]:
    """One run: `latencies_ms` per measured receiver; 4 poses sent."""
    receivers = [
        {"latencies_s": [x / 1e3 for x in lat], "received": len(lat), "cpu_s": cpu_s[f"rx{k}"]}
        for k, lat in enumerate(latencies_ms)
    ]
    return {"transport": name, "sent": 4, "late_sends": 0, "receivers": receivers,
            "cpu_s": cpu_s, "machine_busy": 0.5}  # fmt: skip


def test_pooling_counts_every_receiver_and_divides_cpu_per_pose(report: ModuleType) -> None:
    cpu = {"tx": 0.004, "rx0": 0.002, "rx1": 0.001, "router": 0.001}
    runs = [run("zenoh", [[1, 2, 3, 4], [1, 2]], cpu), run("zenoh", [[5, 6, 7, 8], []], cpu)]
    row = report.pool("zenoh", runs)
    assert row.expected == 16 and len(row.latencies_s) == 10
    assert row.delivery == pytest.approx(10 / 16)
    assert row.publisher_s_per_msg == pytest.approx(0.008 / 8)  # 1 ms a pose
    # receivers: 2 ms over 4 poses, 1 ms over 2, 2 ms over 4 (one received nothing)
    assert row.receiver_s_per_msg == pytest.approx((0.5e-3 + 0.5e-3 + 0.5e-3) / 3)
    assert row.layout_s_per_msg == pytest.approx(2 * 0.008 / 8)
    assert row.p(0.5) == pytest.approx(3.0)  # nearest rank of ten: the fifth


def targets(
    report: ModuleType, pose_ms: float, pose_cpu_s: float
) -> tuple[list[Any], dict[str, Any]]:
    """Rows and runs of one round: bare Zenoh with the node loop at 1 ms and 1 ms of receiver
    CPU over 4 poses (250 µs a pose), bare Zenoh without a loop at 0.5 ms and 0.5 ms of CPU,
    the pose path at `pose_ms` and `pose_cpu_s` over the same 4 poses."""
    runs = {
        "pose": [run("pose", [[pose_ms] * 4], {"tx": 0.001, "rx0": pose_cpu_s}) | {"round": 1}],
        "zenoh-loop": [run("zenoh-loop", [[1.0] * 4], {"tx": 0.001, "rx0": 0.001}) | {"round": 1}],
        "zenoh": [run("zenoh", [[0.5] * 4], {"tx": 0.001, "rx0": 0.0005}) | {"round": 1}],
    }
    return [report.pool(name, name_runs) for name, name_runs in runs.items()], runs


@pytest.mark.parametrize(
    ("pose_ms", "pose_cpu_s", "p50_met", "cpu_met"),
    [(1.2, 0.0015, "meets", "meets"), (1.21, 0.00151, "MISSES", "MISSES")],
)
def test_the_targets_are_judged_against_bare_zenoh_with_the_same_loop(
    report: ModuleType, pose_ms: float, pose_cpu_s: float, p50_met: str, cpu_met: str
) -> None:
    """Issue 41: p50 at most 1.2 x bare Zenoh's, receiver CPU per pose at most 1.5 x, judged
    like for like (bare Zenoh in receivers with the pose path's node loop); the limits
    themselves meet (<=), a hair above misses. The ratio over bare Zenoh without a loop is
    shown beside it: twice the judged one, as that row's figures are half the looped row's."""
    rows, runs = targets(report, pose_ms, pose_cpu_s)
    p50, cpu = report.verdict(rows, runs)
    assert f"p50 / bare Zenoh, node loop's = {pose_ms:.2f}, {p50_met} ≤ 1.2;" in p50
    assert f"over bare Zenoh's (no loop) {2 * pose_ms:.2f}." in p50
    # receiver CPU: pose_cpu_s / 4 poses over 0.001 s / 4 poses
    ratio = pose_cpu_s / 0.001
    assert f"receiver CPU per pose / bare Zenoh, node loop's = {ratio:.2f}, {cpu_met} ≤ 1.5;" in cpu
    assert f"over bare Zenoh's (no loop) {2 * ratio:.2f}." in cpu
    assert "|" in report.table(rows)[2] and "1.00 |" in report.table(rows)[2]


def test_no_target_is_judged_without_the_like_for_like_reference(report: ModuleType) -> None:
    cpu = {"tx": 0.001, "rx0": 0.001}
    runs = {name: [run(name, [[1.0] * 4], cpu) | {"round": 1}] for name in ("pose", "zenoh")}
    rows = [report.pool(name, name_runs) for name, name_runs in runs.items()]
    (line,) = report.verdict(rows, runs)
    assert "not judged, bare Zenoh, node loop was not run" in line


def test_each_round_is_compared_with_the_same_rounds_bare_zenoh(report: ModuleType) -> None:
    """The machine drifts between rounds: a round's ratio pairs the runs of that round, and a
    round whose reference run failed is left out rather than paired with another round."""
    pose = [run("pose", [[ms] * 4], {"tx": 0.001, "rx0": cpu_s}) | {"round": k}
            for k, ms, cpu_s in ((1, 0.4, 0.002), (2, 0.9, 0.009), (3, 0.5, 0.003))]  # fmt: skip
    looped = [run("zenoh-loop", [[ms] * 4], {"tx": 0.001, "rx0": 0.001}) | {"round": k}
              for k, ms in ((1, 0.5), (3, 0.5))]  # fmt: skip
    runs = {"pose": pose, "zenoh-loop": looped}
    ((first, a), (third, b)) = report.round_ratios(runs, "pose", "zenoh-loop")
    assert (first, third) == (1, 3) and (a, b) == pytest.approx((0.8, 1.0))
    rows = [report.pool(name, name_runs) for name, name_runs in runs.items()]
    p50, cpu = report.verdict(rows, runs)
    # pooled: pose's p50 of (0.4, 0.9, 0.5) x 4 is 0.5, the reference's 0.5; round 2 has no pair
    assert "= 1.00, meets ≤ 1.2; each round alone: round 1 0.80, round 3 1.00." in p50
    # receiver CPU per pose: the mean of the runs' (2, 9, 3 ms) / 4 against 1 ms / 4 in each
    # of the reference's: pooled (2 + 9 + 3) / 3 = 4.67, round 1 2.00, round 3 3.00
    assert "= 4.67, MISSES ≤ 1.5; each round alone: round 1 2.00, round 3 3.00." in cpu


def test_py_spy_stacks_are_staged_by_their_method_names(monkeypatch: pytest.MonkeyPatch) -> None:
    """py-spy names methods with their class; a stack is staged by its innermost known step."""
    monkeypatch.syspath_prepend(str(BENCH))
    from collections import Counter

    from peers.profile import hottest, stage_shares

    stacks = Counter({
        "_send_measured (run.py:80);NodeClient.publish_pose (transport/node_client.py:200)": 3,
        "Thread.run (threading.py:1);guarded (guard.py:9);Inbound._on_pose (inbound.py:3)": 1,
    })  # fmt: skip
    shares = dict(stage_shares(stacks))
    assert shares["NodeClient.publish_pose (encode, put)"] == pytest.approx(0.75)
    assert shares["Zenoh pose callback (key parse, hand-over)"] == 0.25
    assert hottest(stacks)[0] == ("NodeClient.publish_pose (node_client.py)", 0.75)


def test_the_callback_steps_are_timed_warm_and_after_idle(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each step of the pose callback gets both figures, warm and spaced, and the totals add
    them up (few calls here: the figures themselves are the benchmark's)."""
    monkeypatch.syspath_prepend(str(BENCH))
    import re

    from peers import steps

    monkeypatch.setattr(steps, "BATCH", 10)
    monkeypatch.setattr(steps, "BATCHES", 2)
    monkeypatch.setattr(steps, "SPACED_CALLS", 3)
    monkeypatch.setattr(steps, "SPACING_S", 0.001)
    line = steps.steps_line()
    pairs = re.findall(r"\) (\d+\.\d) / (\d+\.\d) µs", line)
    assert len(pairs) == 3, line
    warm, spaced = re.search(r"together (\d+\.\d) / (\d+\.\d) µs", line).groups()  # type: ignore[union-attr]
    assert float(warm) == pytest.approx(sum(float(w) for w, _ in pairs), abs=0.3)
    assert float(spaced) == pytest.approx(sum(float(s) for _, s in pairs), abs=0.3)
    assert "one call after each 1 ms idle" in line


def test_receiver_cpu_is_split_by_thread_per_pose(report: ModuleType) -> None:
    """Each group's CPU over the poses each receiver got, averaged over the receivers: 2 ms and
    4 ms of main thread over 4 poses each are 0.5 and 1 ms a pose, 750 µs on average."""
    groups = {"main thread": 0.0, "callback thread": 0.0, "library threads": 0.0,
              "Python threads": 0.0}  # fmt: skip
    runs = {"pose": [run("pose", [[1.0] * 4, [1.0] * 4], {"tx": 0.001, "rx0": 1, "rx1": 1})]}
    for rx, main_s in zip(runs["pose"][0]["receivers"], (0.002, 0.004), strict=True):
        rx["thread_cpu_s"] = groups | {"main thread": main_s, "library threads": 0.0008}
    rows = [report.pool("pose", runs["pose"])]
    (line,) = report.by_thread(rows, runs)
    assert "pose path (this project): main thread 750.0, library threads 200.0." in line
    assert report.by_thread(rows, {"pose": [run("pose", [[1.0] * 4], {"rx0": 1, "tx": 1})]}) == []


def test_threads_are_told_apart_by_who_started_them(monkeypatch: pytest.MonkeyPatch) -> None:
    """A `threading` thread that burns 50 ms of its own CPU time is counted under Python
    threads, and the main thread, which only waits for it meanwhile, gets less than that
    (Linux's per-thread nanosecond counts, read while the worker still lives)."""
    monkeypatch.syspath_prepend(str(BENCH))
    import threading
    import time

    from peers.threads import MAIN, PYTHON, by_group, thread_times

    burnt, release = threading.Event(), threading.Event()

    def burn() -> None:
        end = time.thread_time() + 0.05
        while time.thread_time() < end:
            pass
        burnt.set()
        release.wait()

    before = thread_times()
    worker = threading.Thread(target=burn)
    worker.start()
    assert burnt.wait(30)
    spent = by_group(before, thread_times())
    release.set()
    worker.join()
    assert spent[PYTHON] >= 0.05 * 0.99  # thread_time and schedstat count the same CPU time
    assert spent[MAIN] < 0.05


def test_the_lease_option_reaches_the_fabric_settings_and_zero_keeps_the_fabrics_own(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`--lease-ms` measures what the fabric's keep-alives cost: a run's lease must reach the
    `FabricSettings` of the processes that open their session as the project does, and 0
    must leave the fabric's own lease (2000 ms, docs/protocol.md) in place."""
    monkeypatch.syspath_prepend(str(BENCH))
    from peers.pose_path import _fabric
    from peers.transport import Plan
    from peers.zenoh_bare import lease_option

    def plan(lease_ms: int) -> Plan:
        return Plan("pose", 2, 1, 50.0, 10, (7001, 7002, 7003), {"lease_ms": lease_ms})

    assert lease_option(plan(0)) == {}
    assert _fabric(plan(0), lowlatency=False).lease_ms == 2000
    assert lease_option(plan(10_000)) == {"lease_ms": 10_000}
    assert _fabric(plan(10_000), lowlatency=False).lease_ms == 10_000


def test_the_pose_path_without_a_loop_is_judged_against_bare_zenoh_without_one(
    report: ModuleType,
) -> None:
    """--diagnose runs the pose path whose receivers never run their loop: its like for like
    is bare Zenoh whose receivers only wait, and that pair is judged too (no 'no loop' ratio
    beside it: its reference is that row already)."""
    cpu = {"tx": 0.001, "rx0": 0.001}
    runs = {
        name: [run(name, [[ms] * 4], cpu | {"rx0": rx_s}) | {"round": 1}]
        for name, ms, rx_s in (
            ("pose", 1.0, 0.003), ("zenoh-loop", 1.0, 0.002),
            ("pose-no-loop", 0.6, 0.0016), ("zenoh", 0.5, 0.001),
        )
    }  # fmt: skip
    rows = [report.pool(name, name_runs) for name, name_runs in runs.items()]
    lines = report.verdict(rows, runs)
    assert len(lines) == 4
    p50, cpu_line = lines[2:]
    # 0.6 / 0.5 ms = 1.20 (meets, at the limit); 1.6 / 1.0 ms per 4 poses = 1.60 (misses)
    assert "pose path, no node loop: p50 / bare Zenoh's = 1.20, meets ≤ 1.2; " in p50
    assert (
        "receiver CPU per pose / bare Zenoh's = 1.60, MISSES ≤ 1.5; each round alone: "
        "round 1 1.60." in cpu_line
    )
    assert "(no loop)" not in p50 + cpu_line
