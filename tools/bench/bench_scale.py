"""Benchmark: the fabric at scale — N swarm egos, 500 NPCs, real nodes, one router.

    python tools/bench/bench_scale.py [--egos 16 64 256] [--seconds 15] [--profile] [--write]

One router, one authority running a generated grid town with 500 NPC vehicles (SUMO), two
real nodes (`NodeClient` processes standing at the town's centre) and, for each N, one
`carlaverse swarm --egos N` process whose egos join like nodes and drive around the town's
blocks at 50 Hz, spread over the whole map. The probes:

- `probe-all` hears the whole session (interest radius 0): every pose of every ego, the
  worst case for one node; its one-way latency, delivery and CPU per pose are the figures.
- `probe-near` has the default interest radius (200 m): it subscribes to the 3 × 3 tiles
  around it, so it should hear its neighbours and nothing else, whatever N is.

Per window of `--seconds`: the authority's tick p50/p99/max and overruns (its own timing of
`Authority.tick`, reset at the window start), each probe's poses received, one-way latency
(session time on arrival − the pose's session time; both clocks synchronised to the
authority, the sync bound is shown), delivery (received / sequence numbers spanned per
sender), CPU per pose received, and the CPU of the router, the authority and the swarm from
/proc. A window without swarm comes first: the probes' CPU then is their fixed cost (own
pose, clock sync, NPC batches), subtracted for the marginal cost per pose. `--profile`
records the authority with py-spy during the largest N and prints its top functions.
This is a measurement, not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import scale_profile
from benchdoc import RunInfo, command_line, write_section
from peers.profile import py_spy

SESSION = "scale"
GRID_JUNCTIONS = 8  # per side (a larger generated town takes minutes to build its scenery)
BLOCK_M = 150.0  # [m] between junctions
ATTACH_M = 80.0  # [m] the fringe roads: junction A0 sits at (ATTACH_M, ATTACH_M)
TOWN_M = BLOCK_M * (GRID_JUNCTIONS - 1)  # [m] across the town's junctions
SPREAD_M = 4000.0  # [m] the swarm drives the blocks of a 4 km grid that holds the town
CENTRE = (ATTACH_M + TOWN_M / 2 + 7.0, ATTACH_M + TOWN_M / 2 + 3.0)  # [m] the probes
VEHICLES = 500
FILL_S = 30.0  # [s] for SUMO to insert the NPCs before anything is measured
SETTLE_S = 3.0  # [s] after the swarm joined, before a window
TARGET_TICK_P99_MS = 20.0
TARGET_DELIVERY = 0.999
TARGET_ONE_WAY_P99_MS = 5.0
TARGET_RX_US = 10.0  # [µs] per pose received
CLK_TCK = os.sysconf("SC_CLK_TCK")

SCENARIO = f"""name: scale-bench
seed: 1
map:
  generate:
    kind: grid
    grid: {{junctions: {GRID_JUNCTIONS}, length_m: {BLOCK_M:g}, attach_length_m: {ATTACH_M:g}}}
    lanes: 1
traffic:
  vehicles: {{count: {VEHICLES}, mix: {{car: 0.85, van: 0.1, truck: 0.05}}}}
  action_step_s: 0.2
"""


def proc_cpu_s(pid: int) -> float:
    """User + system CPU time a process has used [s] (from /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


# ---------------------------------------------------------------- the authority (a child)


def authority_main(endpoint: str, scenario: str, conn: Any) -> None:
    from carlaverse.authority.service import Authority, AuthoritySettings
    from carlaverse.authority.traffic_domain import load_domain
    from carlaverse.fabric.clock import WallAlignedClock
    from carlaverse.fabric.session import FabricSettings, open_session

    domain = load_domain(scenario)
    session = open_session(FabricSettings(connect=[endpoint]))
    settings = AuthoritySettings(session=SESSION)
    authority = Authority(session, settings, WallAlignedClock(), domain).start()
    ticking = threading.Thread(target=authority.run, daemon=True)
    ticking.start()
    conn.send(os.getpid())
    while (command := conn.recv()) != "quit":
        if command == "start":
            authority.tick_ms.clear()
            authority.overruns = 0
        elif command == "stop":
            ticks = list(authority.tick_ms)
            conn.send({
                "ticks": len(ticks), "p50": percentile(ticks, 0.5), "p99": percentile(ticks, 0.99),
                "max": max(ticks, default=float("nan")), "overruns": authority.overruns,
                "npcs": len(domain.engine.npcs().ids), "egos": len(authority.roster.tracks),
            })  # fmt: skip
    authority.stop()
    ticking.join(5)  # the tick thread must be done with SUMO before close() ends it
    authority.close()
    session.close()


# ---------------------------------------------------------------- a real node (a child)


class Receipts:
    """What a probe heard in a window; `heard` runs in Zenoh's callback thread."""

    def __init__(self) -> None:
        self.recording = False
        self.latency_s: list[float] = []
        self.seqs: dict[str, list[int]] = {}  # sender -> [first, last, count]

    def heard(self, node_id: str, seq: int, latency_s: float) -> None:
        if not self.recording:
            return
        self.latency_s.append(latency_s)
        span = self.seqs.get(node_id)
        if span is None:
            self.seqs[node_id] = [seq, seq, 1]
        else:
            span[1] = max(span[1], seq)
            span[2] += 1


def probe_main(endpoint: str, node_id: str, radius_m: float, conn: Any) -> None:
    from carlaverse.fabric.clock import MonotonicClock
    from carlaverse.fabric.node_client import NodeClient, NodeSettings
    from carlaverse.fabric.session import FabricSettings, open_session
    from carlaverse.messages import Pose

    session = open_session(FabricSettings(connect=[endpoint]))
    settings = NodeSettings(node_id=node_id, session=SESSION, interest_radius_m=radius_m)
    client = NodeClient(session, settings, MonotonicClock())
    receipts = Receipts()
    push_pose = client.world.push_pose

    def stamped(sender: str, pose: Any, rx_t: float) -> None:
        receipts.heard(sender, pose.seq, rx_t - pose.t)
        push_pose(sender, pose, rx_t)

    client.world.push_pose = stamped  # type: ignore[method-assign]
    client.start(lambda t: Pose(0, t, *CENTRE))
    client.wait_joined(60)
    conn.send("joined")
    started_cpu = started_t = 0.0
    while True:
        if conn.poll(0.01):
            command = conn.recv()
            if command == "quit":
                break
            if command == "start":
                receipts.latency_s, receipts.seqs = [], {}
                started_cpu, started_t = _own_cpu_s(), time.monotonic()
                receipts.recording = True
            elif command == "stop":
                receipts.recording = False
                conn.send(_probe_report(receipts, started_cpu, started_t, client))
        client.update()  # drain the world's inbox as a node's loop would
    client.close()
    session.close()


def floor_main(endpoint: str, conn: Any) -> None:
    """The floor under `probe-all`: a bare zenoh-python subscriber to every pose of the
    session, whose callback only takes the payload's bytes (no project code). Its CPU per pose
    is what any Python node pays to be handed a sample; the fabric's share is the rest."""
    import zenoh

    from carlaverse.fabric.session import FabricSettings, open_session
    from carlaverse.keys import Keys

    session = open_session(FabricSettings(connect=[endpoint]))
    count = [0]

    def on_sample(sample: zenoh.Sample) -> None:
        sample.payload.to_bytes()
        count[0] += 1

    key = Keys(SESSION).all_ego("pose")
    subscriber = session.declare_subscriber(key, zenoh.handlers.Callback(on_sample))
    conn.send("joined")
    started_cpu = started_t = 0.0
    while (command := conn.recv()) != "quit":
        if command == "start":
            count[0], started_cpu, started_t = 0, _own_cpu_s(), time.monotonic()
        elif command == "stop":
            seconds = time.monotonic() - started_t
            conn.send({"seconds": seconds, "cpu_s": _own_cpu_s() - started_cpu, "poses": count[0]})
    subscriber.undeclare()
    session.close()


def _own_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _probe_report(receipts: Receipts, cpu0: float, t0: float, client: Any) -> dict[str, Any]:
    lat = receipts.latency_s
    spanned = sum(last - first + 1 for first, last, _ in receipts.seqs.values())
    return {
        "seconds": time.monotonic() - t0, "cpu_s": _own_cpu_s() - cpu0, "poses": len(lat),
        "senders": len(receipts.seqs), "spanned": spanned,
        "p50_ms": percentile(lat, 0.5) * 1e3, "p99_ms": percentile(lat, 0.99) * 1e3,
        "max_ms": max(lat, default=float("nan")) * 1e3,
        "sync_ms": client.clock.uncertainty_s * 1e3, "tiles": len(client.interest.tiles)
        if client.interest else 0,
    }  # fmt: skip


# ---------------------------------------------------------------- orchestration


class Bench:
    def __init__(self, tmp: Path, seconds: float, fill_s: float) -> None:
        self.tmp = tmp
        self.seconds = seconds
        self.fill_s = fill_s
        self.port = _free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.ctx = mp.get_context("spawn")
        self.children: list[Any] = []
        self.router: subprocess.Popen | None = None

    def start(self) -> None:
        cli = [sys.executable, "-m", "carlaverse"]
        self.router = subprocess.Popen([*cli, "router", "--listen", self.endpoint],
                                       stderr=subprocess.DEVNULL)  # fmt: skip
        scenario = self.tmp / "scale.yaml"
        scenario.write_text(SCENARIO)
        self.authority, self.authority_pid = self._child(authority_main, str(scenario))
        self.probes = {}
        for name, radius in (("probe-all", 0.0), ("probe-near", 200.0)):
            conn, _pid = self._child(probe_main, name, radius)
            self.probes[name] = conn
        self.floor, _pid = self._child(floor_main)
        for conn in (*self.probes.values(), self.floor):
            assert conn.recv() == "joined"
        print(f"town filling for {self.fill_s:g} s ...", file=sys.stderr)
        time.sleep(self.fill_s)

    def _child(self, target: Any, *args: Any) -> tuple[Any, int]:
        ours, theirs = self.ctx.Pipe()
        proc = self.ctx.Process(target=target, args=(self.endpoint, *args, theirs), daemon=True)
        proc.start()
        self.children.append(proc)
        first = ours.recv() if target is authority_main else None
        return ours, (first or proc.pid)

    def window(self, swarm_pid: int | None, profile_to: Path | None = None) -> dict[str, Any]:
        pids = {"router": self.router.pid, "authority": self.authority_pid}  # type: ignore[union-attr]
        if swarm_pid is not None:
            pids["swarm"] = swarm_pid
        cpu0 = {k: proc_cpu_s(p) for k, p in pids.items()}
        t0 = time.monotonic()
        for conn in (self.authority, *self.probes.values(), self.floor):
            conn.send("start")
        spy = _py_spy(self.authority_pid, self.seconds, profile_to) if profile_to else None
        time.sleep(self.seconds)
        for conn in (self.authority, *self.probes.values(), self.floor):
            conn.send("stop")
        wall = time.monotonic() - t0
        out = {"authority": self.authority.recv(),
               "probes": {n: c.recv() for n, c in self.probes.items()},
               "floor": self.floor.recv(),
               "cpu": {k: (proc_cpu_s(p) - cpu0[k]) / wall for k, p in pids.items()}}  # fmt: skip
        if spy is not None:
            spy.wait(60)
        return out

    def run_swarm(self, egos: int, profile_to: Path | None) -> dict[str, Any]:
        cmd = [sys.executable, "-m", "carlaverse", "swarm", "--egos", str(egos), "--session",
               SESSION, "--connect", self.endpoint, "--spread", f"{SPREAD_M:g}", "--block",
               f"{BLOCK_M:g}", "--origin", f"{ATTACH_M:g}", f"{ATTACH_M:g}", "--json"]  # fmt: skip
        swarm = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for line in swarm.stderr:  # type: ignore[union-attr]
            if "egos joined" in line:
                break
        time.sleep(SETTLE_S)
        result = self.window(swarm.pid, profile_to)
        swarm.send_signal(signal.SIGINT)
        out, _ = swarm.communicate(timeout=60)
        result["swarm"] = json.loads(out)
        time.sleep(2.0)  # the egos leave; the next N starts from an empty roster
        return result

    def close(self) -> None:
        conns = (getattr(self, "authority", None), *getattr(self, "probes", {}).values(),
                 getattr(self, "floor", None))  # fmt: skip
        for conn in conns:
            if conn is not None:
                with contextlib.suppress(OSError):  # a child that died must not orphan the router
                    conn.send("quit")
        for proc in self.children:
            proc.join(15)
        if self.router is not None:
            self.router.send_signal(signal.SIGINT)
            self.router.wait(15)


def _py_spy(pid: int, seconds: float, out: Path) -> subprocess.Popen | None:
    program = py_spy()
    if program is None:
        print("--profile needs py-spy: pip install py-spy", file=sys.stderr)
        return None
    cmd = [program, "record", "--pid", str(pid), "--duration", str(int(seconds)), "--format",
           "raw", "--output", str(out), "--nonblocking",
           "--rate", str(scale_profile.SAMPLE_RATE_HZ)]  # fmt: skip
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def top_functions(raw: Path, count: int = 15) -> list[tuple[str, float]]:
    """Functions by the share of samples they were on the stack in (inclusive)."""
    totals: dict[str, int] = {}
    samples = 0
    for line in raw.read_text().splitlines():
        stack, _, n = line.rpartition(" ")
        samples += int(n)
        for frame in set(stack.split(";")):
            totals[frame] = totals.get(frame, 0) + int(n)
    ranked = sorted(totals.items(), key=lambda kv: -kv[1])[:count]
    return [(frame, n / max(samples, 1)) for frame, n in ranked]


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ---------------------------------------------------------------- the report


def _per_pose_us(probe: dict[str, Any], base: dict[str, Any]) -> tuple[float, float]:
    """(all CPU, CPU above the no-swarm window) per pose received [µs]."""
    if not probe["poses"]:
        return float("nan"), float("nan")
    rate = probe["cpu_s"] / probe["seconds"]
    base_rate = base["cpu_s"] / base["seconds"]
    per_s = probe["poses"] / probe["seconds"]
    return rate / per_s * 1e6, (rate - base_rate) / per_s * 1e6


def scale_table(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    rows = [
        "| egos | poses/s sent (of 50 Hz × N) | authority tick p50 / p99 / max ms | overruns | "
        "node one-way p50 / p99 ms | delivery | node µs per pose (all / above idle) | "
        "router CPU | authority CPU | swarm CPU |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n, r in runs.items():
        a, p, cpu = r["authority"], r["probes"]["probe-all"], r["cpu"]
        total_us, marginal_us = _per_pose_us(p, base["probes"]["probe-all"])
        delivery = p["poses"] / p["spanned"] if p["spanned"] else float("nan")
        rows.append(
            f"| {n} | {r['swarm']['poses_per_s']:,.0f} ({r['swarm']['offered_fraction']:.0%}) | "
            f"{a['p50']:.2f} / {a['p99']:.2f} / "
            f"{a['max']:.1f} | {a['overruns']} | {p['p50_ms']:.2f} / {p['p99_ms']:.2f} | "
            f"{delivery:.3%} | {total_us:.1f} / {marginal_us:.1f} | {cpu['router']:.0%} | "
            f"{cpu['authority']:.0%} | {cpu['swarm']:.0%} |"
        )
    return "\n".join(rows)


def interest_table(runs: dict[int, dict[str, Any]]) -> str:
    rows = [
        "| egos on the map | probe-near: egos heard | poses/s received | tiles subscribed | "
        "probe-all: egos heard | poses/s received |",
        "|---|---|---|---|---|---|",
    ]
    for n, r in runs.items():
        near, every = r["probes"]["probe-near"], r["probes"]["probe-all"]
        rows.append(
            f"| {n} | {near['senders']} | {near['poses'] / near['seconds']:,.0f} | "
            f"{near['tiles']} | {every['senders']} | {every['poses'] / every['seconds']:,.0f} |"
        )
    return "\n".join(rows)


def verdicts(runs: dict[int, dict[str, Any]], base: dict[str, Any]) -> str:
    n = max(runs)
    r = runs[n]
    a, p = r["authority"], r["probes"]["probe-all"]
    delivery = p["poses"] / p["spanned"] if p["spanned"] else 0.0
    total_us, marginal_us = _per_pose_us(p, base["probes"]["probe-all"])
    checks = [
        (f"authority tick p99 ≤ {TARGET_TICK_P99_MS:g} ms with no overruns at N = {n}",
         a["p99"] <= TARGET_TICK_P99_MS and a["overruns"] == 0,
         f"p99 {a['p99']:.2f} ms, {a['overruns']} overruns"),
        (f"one node receives ≥ {TARGET_DELIVERY:.1%}", delivery >= TARGET_DELIVERY,
         f"{delivery:.3%}"),
        (f"one-way p99 ≤ {TARGET_ONE_WAY_P99_MS:g} ms", p["p99_ms"] <= TARGET_ONE_WAY_P99_MS,
         f"{p['p99_ms']:.2f} ms"),
        (f"receive cost ≤ {TARGET_RX_US:g} µs per pose (above idle)",
         marginal_us <= TARGET_RX_US, f"{marginal_us:.1f} µs ({total_us:.1f} µs all in); a "
         f"bare zenoh-python subscriber to the same poses in the same run, its callback only "
         f"taking the bytes: {_per_pose_us(r['floor'], base['floor'])[1]:.1f} µs"),
    ]  # fmt: skip
    return "\n".join(f"- {what}: {'met' if ok else 'MISSED'} ({got})." for what, ok, got in checks)


def section(runs: dict[int, dict[str, Any]], base: dict[str, Any], profile: str) -> str:
    sync = max(r["probes"]["probe-all"]["sync_ms"] for r in runs.values())
    ba = base["authority"]
    parts = [
        f"One router, one authority running a generated {GRID_JUNCTIONS} × {GRID_JUNCTIONS} "
        f"grid town ({BLOCK_M:g} m blocks, {TOWN_M / 1000:g} km across) with {VEHICLES} NPC "
        f"vehicles requested ({ba['npcs']} present), two real nodes standing at its centre and "
        f"`carlaverse swarm --egos N` driving blocks of the same street grid over "
        f"{SPREAD_M / 1000:g} km × {SPREAD_M / 1000:g} km at 50 Hz per ego: every ego joins and "
        "is in the collision matrix; those on the town's streets are carried in SUMO, the "
        "others SUMO cannot place (retried each second). Swarm egos render no audio, so "
        "the authority builds no audio scenes for them (it builds a listener's only while "
        "something subscribes to its audio key; 256 listeners' scenes are costed under "
        "Authority audio emitters). All on this machine over "
        f"loopback TCP, {runs[max(runs)]['probes']['probe-all']['seconds']:.0f} s windows. "
        f"Without a swarm the authority ticked at p50 {ba['p50']:.2f} / p99 {ba['p99']:.2f} ms "
        f"with {ba['overruns']} overruns. Read every figure against the load average above: "
        "with other work on both cores, a swarm that cannot send its 50 Hz (the percentage in "
        "the second column) and ticks far over 20 ms measure the machine's contention more "
        "than the fabric.",
        "",
        "The node columns are `probe-all`, a `NodeClient` that hears the whole session: "
        "one-way latency is its session time on arrival minus the pose's session time (both "
        f"clocks synchronised to the authority; sync bound ≤ {sync:.2f} ms), delivery is poses "
        "received over sequence numbers spanned per sender, CPU per pose is the process's CPU "
        "time over poses received (all in: its own pose, clock sync and the NPC batches too) "
        "and the same above its CPU in a window without swarm.",
        "",
        scale_table(runs, base),
        "",
        "Interest management: `probe-near` has the default 200 m interest radius and hears "
        "only the tiles around it; `probe-all` hears everything.",
        "",
        interest_table(runs),
        "",
        verdicts(runs, base),
    ]
    if profile:
        parts += ["", profile]
    return "\n".join(parts)


def profile_text(raw: Path, egos: int, seconds: float, before: dict | None) -> str:
    if not raw.exists():
        return ""
    shares = scale_profile.split(raw, seconds)
    rows = ["| function (file:line) | share of samples |", "|---|---|"]
    rows += [f"| `{frame}` | {share:.0%} |" for frame, share in top_functions(raw)]
    compared = (
        f" beside the same split recorded by this script before ({before['label']}, "
        f"N = {before['egos']})"
        if before
        else ""
    )
    return (
        f"Where the authority's time went at N = {egos} (py-spy at "
        f"{scale_profile.SAMPLE_RATE_HZ} Hz, all threads: the tick and Zenoh's), split into the "
        f"parts of its work as shares of one core{compared}:\n\n"
        + scale_profile.table(shares, before)
        + "\n\nTop functions (inclusive, share of samples):\n\n"
        + "\n".join(rows)
    )


def _profile(raw: Path, egos: int, args: argparse.Namespace) -> str:
    """The profile's text; saves its split when asked (the 'before' of a later run)."""
    before = json.loads(args.profile_before.read_text()) if args.profile_before else None
    if raw.exists() and args.profile_out:
        shares = scale_profile.split(raw, args.seconds)
        scale_profile.save(shares, egos, args.profile_label, args.profile_out)
        shutil.copyfile(raw, args.profile_out.with_suffix(".raw.txt"))  # for a closer look
    return profile_text(raw, egos, args.seconds, before)


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
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        bench = Bench(Path(tmp), args.seconds, args.fill)
        try:
            bench.start()
            base = bench.window(None)
            runs: dict[int, dict[str, Any]] = {}
            for n in args.egos:
                raw = Path(tmp) / f"spy-{n}.txt"
                runs[n] = bench.run_swarm(n, raw if args.profile and n == max(args.egos) else None)
                print(json.dumps({n: runs[n]}, default=str), file=sys.stderr)
            profile = _profile(Path(tmp) / f"spy-{max(args.egos)}.txt", max(args.egos), args)
        finally:
            bench.close()
    body = section(runs, base, profile)
    print(body)
    if args.write:
        write_section("Scale: swarm egos, NPCs and interest", body, command_line(argv), run)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
