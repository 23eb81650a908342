"""Benchmark: this project's pose path against its peers, one workload, one run.

    python tools/bench/bench_peers.py [--seconds 10] [--rounds 3] [--transports pose,dds,...]
                                      [--json] [--write]

The same workload for every transport: the project's 64-byte pose at 50 Hz from 1 publisher
process to 3 measured receiver processes plus 1 more receiver (the pose path's authority,
which receives every pose; elsewhere a receiver process that is not reported), all on
127.0.0.1. Transports: the pose path (NodeClient -> fabric callback -> world view; also with
the fabric's `lowlatency` setting), bare Zenoh (with Zenoh's defaults and in faster set-ups:
the fastest is the floor under any pose path built on Zenoh), CycloneDDS (best effort,
KEEP_LAST 1), ZeroMQ PUB/SUB, MQTT through mosquitto (QoS 0), raw UDP unicast. Each round
runs every transport once, the order rotated from round to round, so the load of a shared
machine falls on all of them alike. One-way latency from the CLOCK_MONOTONIC stamp in the pose
to its decoded arrival; CPU time of every process per pose. The verdict judges issue 41's
targets against bare Zenoh in the same run: the pose path's p50 at most 1.2 times bare Zenoh's,
its receivers' CPU per pose at most 1.5 times. Like for like: the pose path's receivers run a
node's loop (50 Hz on the main thread, applying what arrived), and waking a thread 50 times a
second costs a receiver of one 50 Hz sender as much CPU per pose as Zenoh's own receive; so
the judged reference is bare Zenoh in receivers with the same loop (`zenoh-loop`, which takes
and decodes what its callback kept), and the ratio over bare Zenoh without a loop is shown
beside it.
`tools/bench/peers/` holds the harness. Not a test (tests/bench/test_peers_smoke.py runs it
briefly).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from benchdoc import RunInfo, command_line, write_section
from peers.profile import SAMPLE_RATE_HZ, PySpy, profile_lines
from peers.registry import COMPARED, DIAGNOSTIC, REFERENCE, TRANSPORTS, load
from peers.report import Row, by_thread, pool, split, table, verdict, versions
from peers.run import RunFailed, run_once
from peers.steps import steps_line

TITLE = "Peers: pose path against Zenoh, DDS, ZeroMQ, MQTT and UDP"
DIAGNOSIS = "Peers: where the pose path's time goes"
VARIANTS = (
    "Variants: 'bare Zenoh, direct callback' runs the subscriber's callback on Zenoh's network "
    "thread (`Callback(indirect=False)`) instead of zenoh-python's own Python thread; 'bare "
    "Zenoh, pose publisher options' publishes as `NodeClient` does (drop under congestion, "
    "real-time priority, remote destinations only); 'pose path, no node loop' is the pose path "
    "whose receivers never run `update()`, so the Zenoh callback has each process to itself; "
    "'pose path, pose keys not declared' is the pose path whose receivers declare no pose key "
    "they hear (`transport.key_routes`), so Zenoh matches each sample's key against its whole "
    "routing table, as it did before they did. "
    "Here the pose path's receivers time the fabric's pose callback (two clock reads more per "
    "pose, in their CPU; not in the comparison's runs)."
)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="measured seconds per run")
    parser.add_argument("--rounds", type=int, default=3, help="runs of each transport")
    parser.add_argument("--rate", type=float, default=50.0, help="poses per second [Hz]")
    parser.add_argument("--receivers", type=int, default=3, help="measured receiver processes")
    parser.add_argument(
        "--transports", default=",".join(COMPARED), help=f"from {','.join(TRANSPORTS)}"
    )
    parser.add_argument(
        "--profile", action="store_true", help="one more pose path run under py-spy (its own)"
    )
    parser.add_argument(
        "--diagnose",
        action="store_true",
        help=f"take the pose path apart: {','.join(DIAGNOSTIC)} and py-spy (its own section)",
    )
    parser.add_argument("--native", action="store_true", help="py-spy: name native frames too")
    parser.add_argument(
        "--lease-ms",
        type=int,
        default=0,
        help="the fabric's Zenoh lease [ms] in the router and the pose path's processes "
        "(default: the fabric's own, 2000; Zenoh's default is 10000): what its keep-alives cost",
    )
    parser.add_argument("--json", action="store_true", help="one JSON summary on stdout")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    args.transports = [t.strip() for t in args.transports.split(",") if t.strip()]
    if args.diagnose:
        args.transports, args.profile = list(DIAGNOSTIC), True
    if args.lease_ms < 0:
        parser.error(f"--lease-ms must be 0 (the fabric's own) or a lease in ms: {args.lease_ms}")
    unknown = [t for t in args.transports if t not in TRANSPORTS]
    if unknown:
        parser.error(f"unknown transport {unknown[0]!r}: choose from {', '.join(TRANSPORTS)}")
    return args


def measure(
    args: argparse.Namespace, names: list[str]
) -> tuple[dict[str, list[dict[str, Any]]], list[str]]:
    """Every round runs every transport once, starting one later each round.

    A run that fails is reported (and left out of its transport's figures), not retried.
    """
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in names}
    failed = []
    for k in range(args.rounds):
        for name in names[k % len(names) :] + names[: k % len(names)]:
            outcome = "done"
            try:
                result = run_once(name, args.rate, args.seconds, args.receivers,
                                  time_callback=args.diagnose, lease_ms=args.lease_ms)  # fmt: skip
                runs[name].append(result | {"round": k + 1})
            except RunFailed as exc:
                failed.append(f"round {k + 1}, {load(name).label}: {exc}")
                outcome = f"FAILED: {exc}"
            print(f"round {k + 1}/{args.rounds}: {name} {outcome}", file=sys.stderr)
    return runs, failed


def workload(args: argparse.Namespace) -> str:
    return (
        f"Workload, the same for every transport and run: the project's 64-byte pose at "
        f"{args.rate:g} Hz from 1 publisher process to {args.receivers} measured receiver "
        f"processes and 1 more receiver (the pose path's authority, which receives every pose; "
        f"elsewhere a receiver process not reported), on 127.0.0.1, {args.seconds:g} s "
        f"measured per run after a warm-up, {args.rounds} rounds, each running every transport "
        "once in a rotated order. Latency: one way, from the CLOCK_MONOTONIC stamp the "
        "publisher puts in the pose to the receiver's stamp after decoding it (the pose path: "
        "once the fabric parsed the key and handed the pose's bytes to the world view, which "
        "checks and decodes them in its update, off this path, and the harness decoded them). "
        "CPU: process CPU time (all threads) over the measured window per pose; 'whole "
        "layout' adds every process of the run (receivers, the extra receiver, router, "
        "broker, authority). Settings: CycloneDDS best effort, KEEP_LAST 1, no batching, no "
        "shared memory, unicast discovery on loopback; MQTT QoS 0 with TCP_NODELAY on broker "
        "and clients; ZeroMQ PUB/SUB over TCP; UDP unicast to each receiver; Zenoh peers "
        "(a router for discovery only); 'pose path, lowlatency' sets the fabric's `lowlatency` "
        "(Zenoh's low-latency transport) in all its processes; 'bare Zenoh, node loop' runs "
        "bare Zenoh in receivers whose main thread wakes at 50 Hz, as the pose path's node "
        "loop does, takes the bytes its callback kept, decodes them and keeps each sender's "
        "newest pose (the reference the targets are judged against); 'bare Zenoh, lowlatency, "
        "direct callback' runs Zenoh alone in that transport with its callback on Zenoh's "
        "network thread, and 'bare Zenoh, fastest set-up' adds one Zenoh receive thread per "
        "process (`ZENOH_RUNTIME`, two by default). 'machine busy' is the share of both cores "
        "in use during that transport's runs (other work shares this machine)."
        + (f" The fabric's Zenoh lease: {args.lease_ms} ms (`--lease-ms`; the fabric's own is "
           "2000 ms) in the router and every process of the pose path." if args.lease_ms else "")
    )  # fmt: skip


def summary(rows: list[Row], runs: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """What `--json` prints: the figures of each transport, and every receiver's counts."""
    return {
        row.name: {
            "p50_ms": row.p(0.5),
            "p99_ms": row.p(0.99),
            "delivered": len(row.latencies_s),
            "expected": row.expected,
            "publisher_us_per_pose": row.publisher_s_per_msg * 1e6,
            "receiver_us_per_pose": row.receiver_s_per_msg * 1e6,
            "layout_us_per_pose": row.layout_s_per_msg * 1e6,
            "receivers": [
                {k: v for k, v in rx.items() if k not in ("latencies_s", "in_callback_s")}
                for run in runs[row.name]
                for rx in run["receivers"]
            ],
        }
        for row in rows
    }


def profile(args: argparse.Namespace) -> list[str]:
    """One more run of the pose path with py-spy on its publisher and first receiver."""
    spy = PySpy(args.seconds, args.native)
    run_once(REFERENCE, args.rate, args.seconds, args.receivers, watch=spy)
    native = " with native frames" if args.native else ""
    head = (
        f"Where the pose path's CPU goes: py-spy{native} on its publisher and first receiver "
        f"during one more {args.seconds:g} s run, {SAMPLE_RATE_HZ} samples per second. It "
        "samples Python threads that are running or runnable (a thread waiting for a free core "
        "counts), not those asleep or blocked, and cannot see Zenoh's own Rust threads:"
    )
    return [head, "", *profile_lines(spy, args.seconds)]


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    run = RunInfo.start()
    missing = {name: load(name).missing() for name in args.transports}
    names = [name for name in args.transports if missing[name] is None]
    not_run = [reason for reason in missing.values() if reason is not None]
    for reason in not_run:
        print(f"not run: {reason}", file=sys.stderr)
    runs, failed = measure(args, names)
    rows = [pool(name, runs[name]) for name in names if runs[name]]
    lines = [workload(args), versions(), *([VARIANTS] if args.diagnose else [])]
    lines += ["", *table(rows), "", *verdict(rows, runs), *split(rows, runs)]
    lines += [f"- Not run: {reason}." for reason in not_run]
    lines += [f"- Failed run (left out): {why}." for why in failed]
    if args.diagnose:
        lines += [*by_thread(rows, runs), steps_line()]
    if args.profile:
        lines += ["", *profile(args)]
    text = "\n".join(lines)
    print(json.dumps(summary(rows, runs) | {"failed": failed}) if args.json else text)
    if args.write:
        write_section(DIAGNOSIS if args.diagnose else TITLE, text, command_line(argv), run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
