"""One run of one transport: its processes, the warm-up, the measured window, the counts.

Layout, the same for every transport: 1 publisher process -> `plan.receivers` receiver
processes, of which the first `plan.measured` are reported; the last receiver is a silent
one (the pose path's authority, which receives every pose too; elsewhere a receiver process
whose figures are not reported), so each pose is sent to the same number of processes.
Infrastructure (a Zenoh router for discovery, the mosquitto broker) runs besides.

The publisher sends warm-up poses until every receiver has heard one, and for at least
WARM_UP_S, then `plan.messages` measured poses at `plan.rate_hz`. The CPU window runs from
the first measured send until every measured receiver has them all (or DRAIN_S after the
last send); the CPU time of every process of the run is read by the parent at both ends.
"""

from __future__ import annotations

import os
import queue
import resource
import time
from dataclasses import dataclass
from typing import Any

import psutil

from peers.arrivals import Arrivals
from peers.registry import load
from peers.threads import by_group, thread_times
from peers.transport import Plan, free_ports, process_context, sample

WARM_UP_S = 1.0  # [s] least warm-up, so discovery and presence have settled on every path
START_TIMEOUT_S = 60.0  # [s] for processes to be ready (admission included) on a loaded host
DRAIN_S = 1.0  # [s] longest wait for stragglers after the last measured send
FINISHED_CHECK_S = 0.1  # [s] how often a polled receiver looks whether the run is over


class RunFailed(RuntimeError):
    """A process of the run did not start or report; the message says which and why."""


@dataclass(frozen=True, slots=True)
class Signals:
    """What the processes of one run tell each other (all shareable across processes)."""

    ready: list[Any]  # per receiver: subscribed
    warmed: list[Any]  # per receiver: a warm-up pose arrived
    go: Any  # the parent: every receiver is ready, warm up
    measuring: Any  # the publisher: the first measured pose goes out now
    sent_all: Any  # the publisher: the last measured pose went out
    finished: Any  # the parent: the window is closed, report and leave
    counter: Any  # per receiver: measured poses received so far
    results: Any  # reports and errors, to the parent

    @classmethod
    def make(cls, ctx: Any, receivers: int) -> Signals:
        events = [ctx.Event() for _ in range(2 * receivers + 4)]
        return cls(events[:receivers], events[receivers : 2 * receivers], *events[-4:],
                   ctx.RawArray("q", receivers), ctx.Queue())  # fmt: skip


def publisher_main(name: str, plan: Plan, sig: Signals) -> None:
    try:
        # Opened once the receivers are up: a pose path publisher joined early and silent
        # for longer than the despawn timeout would be despawned and join again.
        if not sig.go.wait(START_TIMEOUT_S):
            raise RunFailed(f"the receivers were not ready within {START_TIMEOUT_S} s")
        sender = load(name).open_sender(plan)
        period_s = 1.0 / plan.rate_hz
        if not _warm_up(sender, sig.warmed, period_s):
            raise RunFailed(f"not every receiver heard the publisher within {START_TIMEOUT_S} s")
        cpu_start_s = cpu_seconds()
        sig.measuring.set()
        late = _send_measured(sender, plan.messages, period_s)
        sig.sent_all.set()
        sig.finished.wait()
        cpu_s = cpu_seconds() - cpu_start_s
        sig.results.put(("publisher", {"sent": plan.messages, "late_sends": late, "cpu_s": cpu_s}))
        sender.close()
    except Exception as exc:  # report it to the parent in one line rather than hang it
        sig.results.put(("error", f"{name} publisher: {type(exc).__name__}: {exc}"))


def cpu_seconds() -> float:
    """This process's CPU time, all threads, user + system [s] (exact, not in clock ticks)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _warm_up(sender: Any, warmed: list[Any], period_s: float) -> bool:
    start = time.monotonic()
    next_t = start
    while time.monotonic() - start < START_TIMEOUT_S:
        sender.send(sample(0, warm_up=True))
        if time.monotonic() - start >= WARM_UP_S and all(e.is_set() for e in warmed):
            return True
        next_t += period_s
        time.sleep(max(0.0, next_t - time.monotonic()))
    return False


def _send_measured(sender: Any, messages: int, period_s: float) -> int:
    """Send poses 1..messages on a fixed schedule; return how many left > 1 ms late."""
    late = 0
    next_t = time.monotonic()
    for index in range(1, messages + 1):
        if time.monotonic() - next_t > 1e-3:
            late += 1
        sender.send(sample(index, warm_up=False))
        next_t += period_s
        time.sleep(max(0.0, next_t - time.monotonic()))
    return late


def receiver_main(name: str, plan: Plan, index: int, sig: Signals) -> None:
    try:
        arrivals = Arrivals(sig.warmed[index], sig.counter, index)
        receiver = load(name).open_receiver(plan, index, arrivals)
        sig.ready[index].set()
        cpu_s, threads_s = _receive_until(receiver, sig.measuring, sig.finished)
        report = getattr(receiver, "report", dict)()
        spent = {"cpu_s": cpu_s, "thread_cpu_s": threads_s}
        sig.results.put(("receiver", index, arrivals.summary() | report | spent))
        receiver.close()
    except Exception as exc:
        sig.results.put(("error", f"{name} receiver {index}: {type(exc).__name__}: {exc}"))


def _receive_until(receiver: Any, measuring: Any, finished: Any) -> tuple[float, dict[str, float]]:
    """Serve the receiver until `finished`; its CPU time [s] since `measuring` was set, and
    that time by thread group (`peers.threads`; read outside the process's figure).

    A receiver that needs its main loop (`poll_period_s`, the pose path's `update()`) gets
    it; the others wait without waking, so no harness work is charged to them.
    """
    period_s = getattr(receiver, "poll_period_s", None)
    if period_s is None:
        measuring.wait()
        threads_start = thread_times()
        cpu_start_s = cpu_seconds()
        finished.wait()
        cpu_s = cpu_seconds() - cpu_start_s
        return cpu_s, by_group(threads_start, thread_times())
    cpu_start_s, threads_start = None, {}
    # `finished` is looked at every FINISHED_CHECK_S, not on every tick: reading a process
    # shared Event takes its semaphores, harness work that would be charged to this receiver
    # alone (the receivers above only wait).
    every = max(1, round(FINISHED_CHECK_S / period_s))
    tick = 0
    while tick % every or not finished.is_set():
        receiver.poll()
        if cpu_start_s is None and measuring.is_set():
            threads_start = thread_times()
            cpu_start_s = cpu_seconds()
        time.sleep(period_s)  # the node loop's own pacing
        tick += 1
    cpu_s = cpu_seconds() - (cpu_start_s or cpu_seconds())
    return cpu_s, by_group(threads_start, thread_times())


def run_once(name: str, rate_hz: float, seconds: float, measured: int, watch: Any = None,
             time_callback: bool = False, lease_ms: int = 0) -> dict[str, Any]:  # fmt: skip
    """Run `name` once; its latencies, counts and CPU times (raises RunFailed).

    `watch` (a profiler) is started with the pid of every process, by role, when the
    measured window opens, and finished when the last measured pose has been sent.
    `time_callback`: the pose path's receivers time the fabric's pose callback (two clock
    reads more per pose, in their CPU; the other transports ignore it). `lease_ms`: the
    fabric's Zenoh lease in the processes that open their session as the project does (the
    router, and every process of the pose path); 0 keeps the fabric's default.
    """
    transport = load(name)
    receivers = measured + 1
    ports = free_ports(receivers + 2)
    # A DDS domain of its own per run (ids 0-232 are valid): a bench running beside another
    # (a test during a measurement) must not discover the other's participants.
    options = {"dds_domain": ports[-1] % 230 + 1, "time_callback": time_callback,
               "lease_ms": lease_ms}  # fmt: skip
    plan = Plan(name, receivers, measured, rate_hz, round(rate_hz * seconds), ports, options)
    infrastructure = transport.infrastructure(plan)
    try:
        for part in infrastructure:
            if not part.wait_ready(START_TIMEOUT_S):
                raise RunFailed(f"{name}: {part.name} did not start within {START_TIMEOUT_S} s")
        spawned = receivers if transport.extra_receiver else measured
        return _measure(plan, spawned, {p.name: p.pid for p in infrastructure}, watch)
    finally:
        for part in infrastructure:
            part.stop()


def _measure(plan: Plan, spawned: int, others: dict[str, int], watch: Any) -> dict[str, Any]:
    ctx = process_context()
    sig = Signals.make(ctx, spawned)
    procs = [ctx.Process(target=receiver_main, name=f"rx{k}", args=(plan.transport, plan, k, sig))
             for k in range(spawned)]  # fmt: skip
    procs.append(ctx.Process(target=publisher_main, name="tx", args=(plan.transport, plan, sig)))
    try:
        _start_all(procs, sig.ready, sig.results)
        sig.go.set()
        _wait_for(procs, [sig.measuring], sig.results)
        window = _window(plan, sig, {p.name: int(p.pid) for p in procs} | others, watch)
        sig.finished.set()
        reports = dict(_expect(sig.results, 30.0) for _ in procs)
    finally:
        sig.finished.set()
        for proc in procs:
            proc.join(timeout=15)
            if proc.is_alive():
                proc.kill()
    return _result(plan, reports, window)


def _window(plan: Plan, sig: Signals, pids: dict[str, int], watch: Any) -> dict[str, Any]:
    """From the first measured send until all arrived: the CPU of processes that do not
    report their own (the infrastructure's) and of the whole machine."""
    others = {role: pid for role, pid in pids.items() if role != "tx" and role[:2] != "rx"}
    others_before, machine_before = _cpu_times(others), psutil.cpu_times()
    if watch is not None:
        watch.start(pids)
    _wait_sent(plan, sig.sent_all, sig.results)
    if watch is not None:
        watch.finish()
    _drain(plan, sig.counter)
    others_after, machine_after = _cpu_times(others), psutil.cpu_times()
    return {
        "others_cpu_s": {role: others_after[role] - others_before[role] for role in others},
        "machine_busy": _busy_fraction(machine_before, machine_after),
    }


def _result(plan: Plan, reports: dict[str, Any], window: dict[str, Any]) -> dict[str, Any]:
    return {
        "transport": plan.transport,
        "sent": reports["tx"]["sent"],
        "late_sends": reports["tx"]["late_sends"],
        "receivers": [reports[f"rx{k}"] for k in range(plan.measured)],
        "cpu_s": {role: r["cpu_s"] for role, r in reports.items()} | window["others_cpu_s"],
        "machine_busy": window["machine_busy"],
        "load_1min": os.getloadavg()[0],
    }


def _wait_sent(plan: Plan, sent_all: Any, results: Any) -> None:
    deadline = time.monotonic() + plan.messages / plan.rate_hz + START_TIMEOUT_S
    while not sent_all.wait(0.1):
        _raise_reported_error(results)
        if time.monotonic() > deadline:
            raise RunFailed(f"{plan.transport}: the publisher did not finish sending in time")


def _drain(plan: Plan, counter: Any) -> None:
    """Wait until every measured receiver has every pose, or DRAIN_S."""
    drain_until = time.monotonic() + DRAIN_S
    while time.monotonic() < drain_until and min(counter[: plan.measured]) < plan.messages:
        time.sleep(0.005)  # counters live in shared memory: polled, briefly


def _start_all(procs: list[Any], ready: list[Any], results: Any) -> None:
    for proc in procs:
        proc.daemon = True
        proc.start()
    _wait_for(procs, ready, results)


def _wait_for(procs: list[Any], events: list[Any], results: Any) -> None:
    """Until every event is set; RunFailed when a process reports an error or dies."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while not all(e.is_set() for e in events):
        _raise_reported_error(results)
        dead = [p.name for p in procs if p.exitcode is not None]
        if dead:
            raise RunFailed(f"{dead} exited before the run began")
        if time.monotonic() > deadline:
            late = [p.name for p, e in zip(procs, events, strict=False) if not e.is_set()]
            raise RunFailed(f"{late or 'the publisher'} not ready within {START_TIMEOUT_S} s")
        time.sleep(0.05)  # the events come from several processes: no single one to wait on


def _raise_reported_error(results: Any) -> None:
    try:
        item = results.get_nowait()
    except queue.Empty:
        return
    if item[0] == "error":
        raise RunFailed(item[1])
    raise RunFailed(f"unexpected report before the measurement: {item[0]}")


def _expect(results: Any, timeout_s: float) -> tuple[str, dict[str, Any]]:
    """The next report, as (role, report): role `tx` or `rx<k>`; RunFailed on an error."""
    try:
        item = results.get(timeout=timeout_s)
    except queue.Empty:
        raise RunFailed(f"a process did not report within {timeout_s:.0f} s") from None
    if item[0] == "error":
        raise RunFailed(item[1])
    return ("tx", item[1]) if item[0] == "publisher" else (f"rx{item[1]}", item[2])


def _cpu_times(pids: dict[str, int]) -> dict[str, float]:
    """CPU seconds (user + system, all threads; clock-tick resolution) of other processes."""
    times = {}
    for role, pid in pids.items():
        t = psutil.Process(pid).cpu_times()
        times[role] = t.user + t.system
    return times


def _busy_fraction(before: Any, after: Any) -> float:
    """Share of the machine's CPU time (all cores) that was not idle between two readings."""
    total = sum(after) - sum(before)
    idle = (after.idle + after.iowait) - (before.idle + before.iowait)
    return 0.0 if total <= 0 else 1.0 - idle / total
