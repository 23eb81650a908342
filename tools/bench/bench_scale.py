"""Benchmark: the fabric at scale — N swarm egos, 500 NPCs, real nodes, one router.

    python tools/bench/bench_scale.py [--egos 16 64 256] [--seconds 15] [--profile] [--write]

One router, one authority running a generated grid town with 500 NPC vehicles (SUMO), real
nodes (`NodeClient` processes standing at the town's centre) and, for each N, one
`carlaverse swarm --egos N` process whose egos join like nodes and drive around the town's
blocks at 50 Hz, spread over the whole map. Three windows of `--seconds` per N:

- the session window: `probe-near`, a node with the default interest radius (200 m), the way
  a participant runs: it subscribes to the 3 × 3 tiles around it, so it should hear its
  neighbours (`probe-mate`, 30 m away, and the swarm egos passing) and nothing else,
  whatever N is;
- the hear-everything window adds `probe-all` (interest radius 0: every pose of every ego,
  the worst case for one node) and a bare zenoh-python subscriber to the same poses, the
  floor under any Python node's receive cost. They run only in this window: on two cores
  they take a core's worth of CPU at N = 256, which the session window should not pay;
- the digest window: the same with `probe-digest` instead of `probe-all`, the same node
  taking every pose through the authority's pose digest (`world/@egos`), so the two ways
  of hearing everything are compared on the same swarm without competing for the cores.

Per window: the authority's tick p50/p99/max and overruns (its own timing of
`Authority.tick`, reset at the window start), each probe's poses received, one-way latency
(session time on arrival − the pose's session time; both clocks synchronised to the
authority, the sync bound is shown), delivery (received / sequence numbers spanned per
sender), CPU per pose received, and the CPU of the router, the authority and the swarm from
/proc. Windows without swarm come first: the probes' CPU then is their fixed cost (own
pose, clock sync, NPC batches), subtracted for the marginal cost per pose. `--profile`
records the authority with py-spy in a third window at the largest N, like the session
window but not measured (py-spy's sampling takes CPU from the others).
This is a measurement, not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import scale_profile
from benchdoc import RunInfo, command_line, process_cpu_s, write_section
from peers.profile import py_spy
from scale_children import SESSION, authority_main, floor_main, probe_main
from scale_layout import (
    ATTACH_M,
    BLOCK_M,
    CENTRE,
    DIGEST_SWEEP_MS,
    FILL_S,
    FLOOR_DRAIN_MS,
    MATE_OFFSET_M,
    NEAR_RADIUS_M,
    ROUNDS,
    SCENARIO,
    SETTLE_S,
    SPREAD_M,
    SWEEP_SETTLE_S,
)
from scale_report import section

from carlaverse import procs
from carlaverse.authority.pose_digest import DIGEST_PERIOD_S
from carlaverse.authority.service import AuthoritySettings
from carlaverse.procs import free_port

SWARM_JOIN_TIMEOUT_S = 300.0  # [s] for a swarm of 256 egos to be admitted on a loaded host
SWARM_REPORT_S = 60.0  # [s] for the swarm to print its report after SIGINT
# ---------------------------------------------------------------- orchestration


class Bench:
    """The processes of the bench. `probe-near` stays for the whole run; `probe-all` or
    `probe-digest`, and the floor subscriber, come up only for the hear-everything and
    digest windows (`hearing()`), so the
    session windows measure the authority beside what a session has: participants that hear
    the actors around them."""

    def __init__(self, tmp: Path, seconds: float, fill_s: float, priority: int) -> None:
        self.priority = priority
        self.tmp = tmp
        self.seconds = seconds
        self.fill_s = fill_s
        self.port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.ctx = mp.get_context("spawn")
        self.children: list[Any] = []
        self.router: procs.Child | None = None
        self.conns: dict[str, Any] = {}  # child name -> its end of the pipe

    def start(self) -> None:
        self.router = procs.start(["router", "--listen", self.endpoint], name="router")
        scenario = self.tmp / "scale.yaml"
        scenario.write_text(SCENARIO)
        self.conns["authority"], _ = self._child(authority_main, str(scenario), self.priority)
        self.authority_pid, self.sumo_pid = self.conns["authority"].recv()
        self.conns["probe-near"], _ = self._child(probe_main, "probe-near", NEAR_RADIUS_M, *CENTRE)
        # A participant standing near probe-near, so it has a neighbour at any N (the swarm
        # spreads 16 egos over 16 km², rarely one within its tiles).
        self.conns["probe-mate"], _ = self._child(probe_main, "probe-mate", NEAR_RADIUS_M,
                                                  CENTRE[0], CENTRE[1] + MATE_OFFSET_M)  # fmt: skip
        for name in ("probe-near", "probe-mate"):
            assert self.conns[name].recv() == "joined", name
        print(f"town filling for {self.fill_s:g} s ...", file=sys.stderr)
        time.sleep(self.fill_s)

    @contextlib.contextmanager
    def hearing(self, digest: bool = False) -> Iterator[None]:
        """A node hearing the whole session and the bare-Zenoh floor, up: `probe-all`, or with
        `digest` `probe-digest` (the same node on the pose digest). One at a time: on two
        cores each takes about half a core at N = 256, and beside each other they would
        measure each other's contention."""
        name = "probe-digest" if digest else "probe-all"
        started = {name: self._child(probe_main, name, 0.0, *CENTRE, digest=digest),
                   "floor": self._child(floor_main)}  # fmt: skip
        with self._up(started):
            yield

    def floors(self, swarm_pid: int | None) -> dict[str, Any]:
        """A window with two bare subscribers to every pose and no probe: `floor` (a Python
        callback per sample) beside `floor-ring` (the samples wait in a Zenoh ring that a
        thread drains every `FLOOR_DRAIN_MS`): whether the floor is the callback's or the
        sample's."""
        started = {"floor": self._child(floor_main),
                   "floor-ring": self._child(floor_main, drain_ms=FLOOR_DRAIN_MS)}  # fmt: skip
        with self._up(started):
            return self.window(swarm_pid)

    @contextlib.contextmanager
    def _up(self, started: dict[str, tuple[Any, Any]]) -> Iterator[None]:
        """`started` children measured in the windows run inside; ended after."""
        for name, (conn, _proc) in started.items():
            assert conn.recv() == "joined", name
            self.conns[name] = conn
        time.sleep(SETTLE_S)
        try:
            yield
        finally:
            for name, (conn, proc) in started.items():
                self.conns.pop(name, None)
                with contextlib.suppress(OSError):
                    conn.send("quit")
                proc.join(15)

    def _child(self, target: Any, *args: Any, **kwargs: Any) -> tuple[Any, Any]:
        ours, theirs = self.ctx.Pipe()
        proc = self.ctx.Process(
            target=target, args=(self.endpoint, *args, theirs), kwargs=kwargs, daemon=True
        )
        proc.start()
        self.children.append(proc)
        return ours, proc

    def window(self, swarm_pid: int | None, profile_to: Path | None = None) -> dict[str, Any]:
        """One measured window: every child's report and the CPU of the router, the
        authority and the swarm."""
        pids = {"router": self.router.proc.pid, "authority": self.authority_pid}  # type: ignore[union-attr]
        if swarm_pid is not None:
            pids["swarm"] = swarm_pid
        if self.sumo_pid is not None:
            pids["sumo"] = self.sumo_pid
        cpu0 = {k: process_cpu_s(p) for k, p in pids.items()}
        t0 = time.monotonic()
        conns = dict(self.conns)
        for conn in conns.values():
            conn.send("start")
        spy = _py_spy(self.authority_pid, self.seconds, profile_to) if profile_to else None
        time.sleep(self.seconds)
        for conn in conns.values():
            conn.send("stop")
        wall = time.monotonic() - t0
        out = {name: conn.recv() for name, conn in conns.items()}
        out["cpu"] = {k: (process_cpu_s(p) - cpu0[k]) / wall for k, p in pids.items()}
        if spy is not None:
            spy.wait(60)
        return out

    def both_windows(self, swarm_pid: int | None, profile_to: Path | None) -> dict[str, Any]:
        """The session window, then the hear-everything window; with `profile_to`, a third
        window like the session one under py-spy (its sampling takes CPU the measured
        windows should not lose)."""
        result = {"session": self.window(swarm_pid)}
        with self.hearing():
            result["hearing"] = self.window(swarm_pid)
        with self.hearing(digest=True):
            for ms in DIGEST_SWEEP_MS:  # the shipped period last: the relay keeps it after
                self.conns["authority"].send(("digest_ms", ms))
                assert self.conns["authority"].recv() == "ok"
                time.sleep(SWEEP_SETTLE_S)
                result[f"digest@{ms:g}"] = self.window(swarm_pid)
        result["digest"] = result[f"digest@{DIGEST_PERIOD_S * 1e3:g}"]
        if profile_to is not None:
            result["profiled"] = self.window(swarm_pid, profile_to)
        return result

    def run_swarm(
        self,
        egos: int,
        profile_to: Path | None,
        express: bool = False,
        rounds: int = 1,
        floors: bool = False,
    ) -> dict[str, Any]:
        """A swarm of `egos` and its windows; `express`: its poses in frames of their own;
        `rounds` > 1: the hear-everything and digest windows that many times, alternating
        (`rounds` in the result), so the two ways of hearing everything are compared on
        medians rather than on one window each; `floors`: the floors' window too."""
        argv = ["swarm", "--egos", str(egos), "--session", SESSION, "--connect", self.endpoint,
                "--spread", f"{SPREAD_M:g}", "--block", f"{BLOCK_M:g}", "--origin",
                f"{ATTACH_M:g}", f"{ATTACH_M:g}", "--json",
                *(["--express"] if express else [])]  # fmt: skip
        swarm = procs.start(argv, name="swarm")
        try:
            swarm.wait_for_line(lambda line: "egos joined" in line, SWARM_JOIN_TIMEOUT_S)
            result = self._swarm_windows(swarm.proc.pid, profile_to, rounds, floors)
            procs.stop_children([swarm], grace_s=SWARM_REPORT_S)  # it reports on SIGINT
        finally:  # a window that failed must not leave 256 egos sending into the next run
            procs.stop_children([swarm], grace_s=0.0)
        result["swarm"] = swarm.json()
        time.sleep(2.0)  # the egos leave; the next N starts from an empty roster
        return result

    def _swarm_windows(
        self, swarm_pid: int, profile_to: Path | None, rounds: int, floors: bool
    ) -> dict[str, Any]:
        time.sleep(SETTLE_S)
        result = self.both_windows(swarm_pid, profile_to)
        result["rounds"] = [{"hearing": result["hearing"], "digest": result["digest"]}]
        for _ in range(rounds - 1):
            again = {}
            with self.hearing():
                again["hearing"] = self.window(swarm_pid)
            with self.hearing(digest=True):
                again["digest"] = self.window(swarm_pid)
            result["rounds"].append(again)
        if floors:
            result["floors"] = self.floors(swarm_pid)
        return result

    def close(self) -> None:
        for conn in self.conns.values():
            with contextlib.suppress(OSError):  # a child that died must not orphan the router
                conn.send("quit")
        for proc in self.children:
            proc.join(15)
        if self.router is not None:
            procs.stop_children([self.router])


def _py_spy(pid: int, seconds: float, out: Path) -> subprocess.Popen | None:
    program = py_spy()
    if program is None:
        print("--profile needs py-spy: pip install py-spy", file=sys.stderr)
        return None
    cmd = [program, "record", "--pid", str(pid), "--duration", str(int(seconds)), "--format",
           "raw", "--output", str(out), "--nonblocking", "--subprocesses", "--idle",
           "--rate", str(scale_profile.SAMPLE_RATE_HZ)]  # fmt: skip
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _profile(raw: Path, egos: int, args: argparse.Namespace) -> str:
    """The profile's text; saves its split when asked (the 'before' of a later run)."""
    before = json.loads(args.profile_before.read_text()) if args.profile_before else None
    if raw.exists() and args.profile_out:
        shares = scale_profile.split(raw, args.seconds)
        scale_profile.save(shares, egos, args.profile_label, args.profile_out)
        shutil.copyfile(raw, args.profile_out.with_suffix(".raw.txt"))  # for a closer look
    return scale_profile.text(raw, egos, args.seconds, before)


def main(argv: list[str] | None = None) -> int:
    run = RunInfo.start()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--egos", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--fill", type=float, default=FILL_S, help="seconds for NPCs to insert")
    parser.add_argument("--profile", action="store_true", help="py-spy the authority")
    parser.add_argument("--profile-out", type=Path, help="save the largest N's split (JSON)")
    parser.add_argument("--profile-label", default="", help="what the saved split measured")
    parser.add_argument("--profile-before", type=Path, help="a saved split to compare with")
    parser.add_argument("--rounds", type=int, default=ROUNDS, metavar="K",
                        help="at the largest N, the hear-everything and digest windows K times, "
                        f"alternating, judged on medians (default {ROUNDS})")  # fmt: skip
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md")
    parser.add_argument("--express-egos", type=int, metavar="N",
                        help="after the runs, N egos once more with every pose in a frame of "
                        "its own (`swarm --express`), as N separate machines send them "
                        "(default: the largest --egos; 0: skip)")  # fmt: skip
    parser.add_argument(
        "--tick-priority",
        type=int,
        default=AuthoritySettings().tick_priority,
        help="the authority's tick_priority (default: the shipped default)",
    )
    args = parser.parse_args(argv)
    express_n = max(args.egos) if args.express_egos is None else args.express_egos
    with tempfile.TemporaryDirectory() as tmp:
        bench = Bench(Path(tmp), args.seconds, args.fill, args.tick_priority)
        try:
            bench.start()
            base = bench.both_windows(None, None)
            base["floors"] = bench.floors(None)
            runs: dict[int, dict[str, Any]] = {}
            for n in args.egos:
                raw = Path(tmp) / f"spy-{n}.txt"
                largest = n == max(args.egos)
                runs[n] = bench.run_swarm(n, raw if args.profile and largest else None,
                                          rounds=args.rounds if largest else 1,
                                          floors=largest)  # fmt: skip
                print(json.dumps({n: runs[n]}, default=str), file=sys.stderr)
            express = (
                {express_n: bench.run_swarm(express_n, None, express=True)} if express_n else {}
            )
            print(json.dumps({"express": express}, default=str), file=sys.stderr)
            profile = _profile(Path(tmp) / f"spy-{max(args.egos)}.txt", max(args.egos), args)
            print(json.dumps({"base": base}, default=str), file=sys.stderr)
        finally:
            bench.close()
    body = section(runs, base, profile, express)
    print(body)
    if args.write:
        write_section("Scale: swarm egos, NPCs and interest", body, command_line(argv), run)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
