"""Benchmark: how close an LSL sample's recorded session time is to the truth, on one host.

    python tools/bench/bench_lsl_time.py [--seconds 20] [--rate 250] [--write]

Three processes on loopback, as in a lab on one PC: a stand-in authority answering
`authority/clock` with session time = LSL local_clock() + a fixed offset (so the truth is
known without the code measured); a synthetic ECG outlet (one channel at `--rate` Hz) that
stamps sample i with the LSL time of its session time t0 + i / rate; and, here, the study's
LSL recorder (`carlaverse.study.lsl_record`) writing an MCAP, read back afterwards. The error
is recorded session time minus truth, per sample: it holds the session clock's offset error
(a Zenoh clock query's half round trip), liblsl's time correction between the two processes,
and nothing else (the sample's own stamp is exact by construction). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import zenoh
from benchdoc import RunInfo, command_line, write_section

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.procs import free_port
from carlaverse.recording.reading import iter_samples
from carlaverse.study.lsl_api import LslNetwork, load
from carlaverse.study.lsl_record import record_lsl
from carlaverse.study.lsl_sink import SharedSink, decode_sample
from carlaverse.transport.session import FabricSettings, open_session

SESSION_OFFSET_S = 1.5e9 + 1234.5678  # [s] the stand-in authority's session − LSL clock
SESSION = "lslbench"


def _network(session_id: str) -> LslNetwork:
    return LslNetwork("machine", session_id)


def authority(endpoint: str) -> int:
    """Child: answer clock queries until stdin closes."""
    pylsl = load(_network("unused"))
    session = open_session(FabricSettings(listen=[endpoint]))

    def reply(query: zenoh.Query) -> None:
        now = pylsl.local_clock() + SESSION_OFFSET_S
        query.reply(query.key_expr, m.CLOCK_REPLY.encode(m.ClockReply(now)))

    queryable = session.declare_queryable(Keys(SESSION).authority("clock"), reply)
    print("ready", flush=True)
    sys.stdin.read()
    queryable.undeclare()
    session.close()
    return 0


def outlet(session_id: str, seconds: float, rate: float) -> int:
    """Child: send the ECG in real time once an inlet is there; print t0 and the count."""
    pylsl = load(_network(session_id))
    info = pylsl.StreamInfo("BenchECG", "ECG", 1, rate, "float32", "bench-ecg")
    out = pylsl.StreamOutlet(info)
    print("ready", flush=True)
    if not out.wait_for_consumers(30):
        return 1
    t0 = math.ceil(pylsl.local_clock() + 0.5) + SESSION_OFFSET_S
    n = round(seconds * rate)
    for start in range(0, n, 10):  # chunks of 10 samples (40 ms at 250 Hz), paced by the clock
        idx = range(start, min(start + 10, n))
        while pylsl.local_clock() < t0 + idx[-1] / rate - SESSION_OFFSET_S:
            time.sleep(0.002)
        for i in idx:
            out.push_sample([math.sin(i / 10)], t0 + i / rate - SESSION_OFFSET_S)
    print(json.dumps({"t0": t0, "n": n}), flush=True)
    time.sleep(1.0)  # the inlet drains before the outlet goes
    return 0


def measure(seconds: float, rate: float) -> dict[str, float]:  # [ms] but n, recorded, liblsl
    session_id = f"bench-{os.getpid()}"
    pylsl = load(_network(session_id))  # this process's configuration, before any other use
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    me = [sys.executable, __file__]
    auth = subprocess.Popen([*me, "--role", "authority", endpoint], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)  # fmt: skip
    ecg = subprocess.Popen([*me, "--role", "outlet", session_id, str(seconds), str(rate)],
                           stdout=subprocess.PIPE, text=True)  # fmt: skip
    assert auth.stdout and ecg.stdout and auth.stdin
    assert auth.stdout.readline().strip() == "ready" and ecg.stdout.readline().strip() == "ready"
    client = open_session(FabricSettings(connect=[endpoint]))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        sink = SharedSink(path, monotonic=time.monotonic)
        recording = record_lsl(client, Keys(SESSION), sink, pylsl, ["BenchECG"], timeout_s=10)
        truth = json.loads(ecg.stdout.readline())
        deadline = time.monotonic() + 10
        while recording.stats()[0].samples < truth["n"] and time.monotonic() < deadline:
            time.sleep(0.05)
        (stats,) = recording.stop()
        bound_s = recording.follower.uncertainty_s
        sink.close()
        samples = [decode_sample(s.payload) for s in iter_samples(path) if s.key == "lsl/BenchECG"]
    auth.stdin.close()
    auth.wait(10)
    ecg.wait(10)
    client.close()
    errors = sorted(abs(s.t - (truth["t0"] + s.seq / rate)) * 1e3 for s in samples)
    return {
        "n": truth["n"],
        "recorded": len(samples),
        "p50": errors[len(errors) // 2],
        "p99": errors[min(len(errors) - 1, int(len(errors) * 0.99))],
        "max": errors[-1],
        "bound": bound_s * 1e3,
        "correction": stats.correction_s * 1e3,
        "liblsl": pylsl.library_version(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="ECG sent [s]")
    parser.add_argument("--rate", type=float, default=250.0, help="ECG sample rate [Hz]")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    parser.add_argument("--role", nargs="+", help=argparse.SUPPRESS)  # the child processes
    args = parser.parse_args(argv)
    if args.role:
        role, *rest = args.role
        if role == "authority":
            return authority(rest[0])
        return outlet(rest[0], float(rest[1]), float(rest[2]))
    run = RunInfo.start()
    r = measure(args.seconds, args.rate)
    lines = [
        "| ECG samples sent | recorded | error p50 ms | p99 ms | max ms "
        "| session clock bound ms | LSL time correction ms |",
        "|---|---|---|---|---|---|---|",
        f"| {r['n']} | {r['recorded']} | {r['p50']:.3f} | {r['p99']:.3f} | {r['max']:.3f} "
        f"| {r['bound']:.3f} | {r['correction']:.4f} |",
        "",
        f"{args.seconds:g} s of a {args.rate:g} Hz one-channel ECG from an outlet process, "
        "recorded by `record_lsl` against a stand-in authority process on loopback. Error: "
        "|recorded session time − true session time| per sample. The session clock bound is "
        "half the best clock query's round trip (`SessionClock.uncertainty_s`) at the end; "
        "the tests hold recorded times to 5 ms of the truth (tests/study/test_lsl_record.py). "
        "Between hosts, add liblsl's time-correction error (pylsl's `time_correction` "
        "docstring: below 1 ms, empirically within ±0.2 ms) and the Zenoh path's asymmetry.",
        f"LSL: pylsl {metadata.version('pylsl')}, liblsl {r['liblsl']:.0f} (its version number).",
    ]
    print("\n".join(lines), flush=True)
    if args.write:
        write_section("LSL to session time", "\n".join(lines), command_line(argv), run)
    return 0


if __name__ == "__main__":
    sys.exit(main())
