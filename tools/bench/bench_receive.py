"""Benchmark: what a node pays in CPU per pose it receives, layer by layer.

    python tools/bench/bench_receive.py [--egos 256] [--rate 50] [--seconds 8] [--rounds 3]
                                        [--modes peer client] [--json raw.json] [--write]

One router on loopback and one publisher process sending the poses of `--egos` egos at
`--rate` Hz each, the same stream for every layer. Then, one at a time (so that no two compete
for the cores), a subscriber process opens a session to the router in peer or client mode,
subscribes to every ego's pose, and measures its own CPU over a window (getrusage: all its
threads, Zenoh's Rust ones too). The layers, each one more of a node's receive path:

- zenoh: a ring channel nobody drains. Zenoh's own (Rust) cost per sample; no Python runs.
  It cannot count what it gets, so its poses are the ones the publisher sent in the window
  (the `handoff` layer's count shows how close delivery comes to that).
- handoff: a callback that takes the payload's bytes and counts: what any Python node pays to
  be handed a sample.
- inbound: the project's pose handler (`Inbound.pose_handler`) into a `WorldView` whose inbox
  nobody drains: parse the key, decode, stamp with the session clock, queue.
- node: as inbound, plus a thread applying the inbox (`WorldView.update`) every 10 ms as a
  node's 100 Hz loop does; that thread's own CPU per pose is reported apart as well.

An idle window per mode (a session subscribed to the poses, the publisher paused) gives what
a session costs with nothing arriving; it is subtracted. A round runs every window once in
turn, so the machine's drift hits all layers alike; the report gives the median over rounds
and their range. A measurement, not a test: run it on an otherwise quiet machine.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import signal
import socket
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from benchdoc import RunInfo, command_line, write_section
from receive_children import EXPRESS, IDLE, publisher_main, subscriber_main

TITLE = "Receive cost per pose, layer by layer"
LAYERS = ("zenoh", "handoff", "inbound", "node")  # each adds to the one before
# The same layers while the publisher puts `express`: one frame per pose, as a node meets
# egos that are machines of their own with direct links (peer mode); one process's egos, and
# a router's fan-out, otherwise share frames.
EXPRESS_LAYERS = ("zenoh" + EXPRESS, "node" + EXPRESS)
MODES = ("peer", "client")
TARGET_US = 10.0  # [µs] the target: receive cost per pose
JOIN_S = 60.0  # [s] for a child to open its session and subscribe
REPLY_S = 30.0  # [s] for a child to answer a command
QUIT_S = 15.0  # [s] for a child or the router to end when asked
WHAT = {
    IDLE: "a session subscribed to the poses, the publisher paused",
    "zenoh": "ring channel never drained: Zenoh's own work, no Python",
    "handoff": "Python callback taking the payload's bytes",
    "inbound": "the project's pose handler into a world view",
    "node": "as inbound, plus `WorldView.update` at 100 Hz",
    "zenoh" + EXPRESS: "as `zenoh`, every pose put express (a frame of its own)",
    "node" + EXPRESS: "as `node`, every pose put express (a frame of its own)",
}


class BenchError(RuntimeError):
    """A process of the bench failed or stopped answering; the message names which."""


# ---------------------------------------------------------------- orchestration


@dataclass
class Child:
    """A child process and our end of its pipe; every wait has a deadline and fails at once,
    naming the child, if the child dies."""

    name: str
    proc: Any  # a multiprocessing process of the spawn context
    conn: Connection

    def ask(self, command: str, timeout_s: float = REPLY_S) -> Any:
        try:
            self.conn.send(command)
        except OSError as exc:
            raise self._died() from exc
        return self.reply(timeout_s)

    def reply(self, timeout_s: float) -> Any:
        ready = wait([self.conn, self.proc.sentinel], timeout_s)
        if self.conn in ready:
            with contextlib.suppress(EOFError):
                return self.conn.recv()
        if ready:
            raise self._died()
        raise BenchError(f"{self.name}: no answer within {timeout_s:g} s (overloaded machine?)")

    def hold(self, seconds: float) -> None:
        """Let `seconds` pass, failing at once if the child dies meanwhile."""
        if wait([self.proc.sentinel], seconds):
            raise self._died()

    def _died(self) -> BenchError:
        self.proc.join(1)
        return BenchError(f"{self.name} died (exit code {self.proc.exitcode}); see its stderr")

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.conn.send("quit")
        self.proc.join(QUIT_S)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(5)


class Bench:
    """The router, the publisher, and one subscriber at a time."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.ctx = mp.get_context("spawn")
        self.port = _free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.router: subprocess.Popen[bytes] | None = None
        self.publisher: Child | None = None

    def start(self) -> None:
        cli = [sys.executable, "-m", "carlaverse", "router", "--listen", self.endpoint]
        quiet = subprocess.DEVNULL  # its "listening" line would land in the printed body
        self.router = subprocess.Popen(cli, stdout=quiet, stderr=quiet)
        _wait_listening(self.router, self.port, JOIN_S)
        self.publisher = self._spawn("publisher", publisher_main, self.args.egos, self.args.rate)
        self.publisher.reply(JOIN_S)

    def sending(self, how: str) -> None:
        """`publish`, `publish-express` or `pause`."""
        assert self.publisher is not None
        self.publisher.ask(how)

    def window(self, mode: str, layer: str) -> dict[str, Any]:
        """One subscriber process of `layer`: joined, warmed up, measured, gone."""
        assert self.publisher is not None
        child = self._spawn(f"subscriber {mode}/{layer}", subscriber_main, mode, layer,
                            self.args.egos)  # fmt: skip
        try:
            child.reply(JOIN_S)
            child.hold(self.args.warmup)
            child.ask("start")
            before = self.publisher.ask("mark")
            child.hold(self.args.seconds)
            report = child.ask("stop")
            after = self.publisher.ask("mark")
        finally:
            child.close()
        report["sent"] = _sent_in(report["seconds"], before, after)
        return report

    def _spawn(self, name: str, target: Callable[..., None], *args: Any) -> Child:
        ours, theirs = self.ctx.Pipe()
        proc = self.ctx.Process(target=target, args=(self.endpoint, *args, theirs), name=name,
                                daemon=True)  # fmt: skip
        proc.start()
        theirs.close()  # ours alone holds the pipe's other end: a dead child reads as EOF
        return Child(name, proc, ours)

    def close(self) -> None:
        if self.publisher is not None:
            self.publisher.close()
        if self.router is not None and self.router.poll() is None:
            self.router.send_signal(signal.SIGINT)
            try:
                self.router.wait(QUIT_S)
            except subprocess.TimeoutExpired:
                self.router.kill()
                self.router.wait(5)


def _sent_in(seconds: float, before: tuple[int, float], after: tuple[int, float]) -> float:
    """Poses the publisher sent in a window of `seconds`: its rate between the two marks (taken
    just after the subscriber's start and stop, on the same monotonic clock) times `seconds`."""
    (n0, t0), (n1, t1) = before, after
    return (n1 - n0) / (t1 - t0) * seconds


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_listening(router: subprocess.Popen[bytes], port: int, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if router.poll() is not None:
            raise BenchError(f"the router exited with code {router.returncode} before listening")
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.5):
            return
        time.sleep(0.05)  # polling a condition under a deadline, not a guess at a duration
    raise BenchError(f"the router did not listen on port {port} within {timeout_s:g} s")


def run_rounds(bench: Bench, args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every mode's idle window (publisher paused), then every (mode, layer), per round."""
    windows = []
    for r in range(args.rounds):
        for how, layers in (("pause", [IDLE]), ("publish", LAYERS),
                            ("publish-express", EXPRESS_LAYERS)):  # fmt: skip
            bench.sending(how)
            for mode in args.modes:
                for layer in layers:
                    windows.append(_measured(bench, r, mode, layer, args.rounds))
    return windows


def _measured(bench: Bench, r: int, mode: str, layer: str, rounds: int) -> dict[str, Any]:
    window = {"round": r, "mode": mode, "layer": layer, **bench.window(mode, layer)}
    rate = poses(window) / window["seconds"]
    share = window["cpu_s"] / window["seconds"]
    each = f", {window['cpu_s'] / poses(window) * 1e6:.1f} µs per pose all in" if rate else ""
    print(f"round {r + 1}/{rounds} {mode:6} {layer:13} {rate:7.0f} poses/s, "
          f"{share:6.1%} of a core{each}", file=sys.stderr, flush=True)  # fmt: skip
    return window


def poses(window: dict[str, Any]) -> float:
    """Poses the window's layer was handed: counted, or (the ring) those sent meanwhile."""
    if window["layer"] == IDLE:
        return 0.0
    received = window["received"]
    return window["sent"] if received is None else received


# ---------------------------------------------------------------- the report


@dataclass
class Figures:
    """One layer in one mode, one value per round."""

    rate: list[float] = field(default_factory=list)  # [poses/s]
    us: list[float] = field(default_factory=list)  # [µs/pose] above idle
    step: list[float] = field(default_factory=list)  # [µs/pose] over the layer before
    share: list[float] = field(default_factory=list)  # of a core, the whole process
    update_us: list[float] = field(default_factory=list)  # [µs/pose] the update thread's
    p50_ms: list[float] = field(default_factory=list)  # one-way, publisher to world view
    p99_ms: list[float] = field(default_factory=list)


def summarise(windows: list[dict[str, Any]], modes: list[str]) -> dict[str, dict[str, Figures]]:
    """Per mode and layer, the figures of every round; the idle window of the same round and
    mode is subtracted, and each step is taken within one round (both saw the same drift)."""
    by = {(w["round"], w["mode"], w["layer"]): w for w in windows}
    rounds = sorted({w["round"] for w in windows})
    out: dict[str, dict[str, Figures]] = {}
    for mode in modes:
        out[mode] = {layer: Figures() for layer in (IDLE, *LAYERS, *EXPRESS_LAYERS)}
        for r in rounds:
            idle = by[(r, mode, IDLE)]
            out[mode][IDLE].share.append(idle["cpu_s"] / idle["seconds"])
            us: dict[str, float] = {}
            for layer in (*LAYERS, *EXPRESS_LAYERS):
                us[layer] = _add(out[mode][layer], by[(r, mode, layer)], idle)
                if (under := _under(layer)) is not None:
                    out[mode][layer].step.append(us[layer] - us[under])
    return out


def _under(layer: str) -> str | None:
    """What a layer's step is taken over: the layer before it, or itself put batched."""
    if layer.endswith(EXPRESS):
        return layer.removesuffix(EXPRESS)
    at = LAYERS.index(layer)
    return LAYERS[at - 1] if at else None


def _add(figures: Figures, w: dict[str, Any], idle: dict[str, Any]) -> float:
    n = poses(w)
    above_s = w["cpu_s"] - idle["cpu_s"] / idle["seconds"] * w["seconds"]
    us = above_s / n * 1e6 if n else float("nan")
    figures.rate.append(n / w["seconds"])
    figures.us.append(us)
    figures.share.append(w["cpu_s"] / w["seconds"])
    if w["layer"].startswith("node"):
        figures.update_us.append(w["update_cpu_s"] / n * 1e6 if n else float("nan"))
    if "latency_ms" in w:
        figures.p50_ms.append(w["latency_ms"][0])
        figures.p99_ms.append(w["latency_ms"][1])
    return us


def _spread(values: list[float], digits: int = 1, scale: float = 1.0, unit: str = "") -> str:
    """The median, and the range over rounds when there is more than one."""
    if not values:
        return "—"
    v = [x * scale for x in values]
    text = f"{statistics.median(v):.{digits}f}{unit}"
    return text if len(v) == 1 else f"{text} ({min(v):.{digits}f}–{max(v):.{digits}f})"


def table(figures: dict[str, Figures]) -> str:
    head = [
        "| layer | what it does | poses/s | µs per pose above idle | over the layer before "
        "(express: over the same layer put as nodes do) "
        "| share of a core | of which the update thread, µs per pose |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    rows = []
    for layer, f in figures.items():
        cells = [f"`{layer}`", WHAT[layer], _spread(f.rate, 0), _spread(f.us),
                 _spread(f.step, unit=" µs"), _spread(f.share, 1, 100, " %"),
                 _spread(f.update_us)]  # fmt: skip
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(head + rows)


def delays(summary: dict[str, dict[str, Figures]]) -> str:
    """What each mode costs in delay: one-way, from the publisher's put to the pose handler."""
    lines = [
        "One-way delay of the `node` layer's poses (send time to the handler's arrival stamp, "
        "one host's clock), p50 / p99:"
    ]
    for mode, f in summary.items():
        for layer in ("node", "node" + EXPRESS):
            node = f[layer]
            lines.append(f"{mode} mode, `{layer}`: {_spread(node.p50_ms, 2)} / "
                         f"{_spread(node.p99_ms, 2)} ms.")  # fmt: skip
    return " ".join(lines)


def verdict(summary: dict[str, dict[str, Figures]]) -> str:
    """Where Zenoh's floor and the hand-off floor stand against the target, from the figures."""
    lines = [f"The target is a receive cost of at most {TARGET_US:g} µs per pose."]
    for mode, f in summary.items():
        floor, handed, node = (statistics.median(f[k].us) for k in ("zenoh", "handoff", "node"))
        room = (
            f"leaving {TARGET_US - floor:.1f} µs for everything Python does"
            if floor < TARGET_US
            else "leaving nothing for Python: this path cannot meet the target on this machine"
        )
        lines.append(
            f"In {mode} mode Zenoh's own floor (`zenoh`) is {floor:.1f} µs per pose, "
            f"{floor / TARGET_US:.0%} of the target, {room}; being handed the sample in Python "
            f"(`handoff`) takes it to {handed:.1f} µs, {_against(handed)}, before any of the "
            f"project's code runs; a node with its world view (`node`) pays {node:.1f} µs, "
            f"{node / TARGET_US:.1f}× the target."
        )
        alone, node_alone = (statistics.median(f[k + EXPRESS].us) for k in ("zenoh", "node"))
        lines.append(
            f"With a frame per pose (`+express`) Zenoh's floor is {alone:.1f} µs and the node "
            f"pays {node_alone:.1f} µs."
        )
    return " ".join(lines)


def _against(us: float) -> str:
    if us <= TARGET_US:
        return f"within the target by {TARGET_US - us:.1f} µs"
    return f"{us - TARGET_US:.1f} µs over the target"


def _rounds(n: int) -> str:
    if n == 1:
        return "One round: one value per figure."
    return f"{n} rounds, every window once in each; figures are medians (range over rounds)."


def paths(windows: list[dict[str, Any]]) -> str:
    """Which way the poses came in each mode, from the links the subscribers held."""
    said = []
    for mode in dict.fromkeys(w["mode"] for w in windows):
        peers = [w["peers"] for w in windows if w["mode"] == mode and w["layer"] != IDLE]
        if min(peers) > 0:
            said.append(
                f"in {mode} mode every subscriber held a direct link to the publisher "
                "(learnt through the router), so the poses could skip the router"
            )
        elif max(peers) == 0:
            said.append(f"in {mode} mode no subscriber held a link but the router's")
        else:
            said.append(
                f"in {mode} mode some subscribers held a direct link to the publisher "
                "and some did not"
            )
    return "Links: " + "; ".join(said) + "."


def section(
    summary: dict[str, dict[str, Figures]], windows: list[dict[str, Any]], args: argparse.Namespace
) -> str:
    intro = (
        f"{args.egos} egos at {args.rate:g} Hz each ({args.egos * args.rate:.0f} poses/s) from "
        "one publisher process, a peer of one router, all on this machine over loopback TCP. "
        "Each layer is a subscriber process of its own, alone on the stream while it is "
        "measured (its whole process: getrusage over all threads, Zenoh's own included), "
        f"{args.warmup:g} s after it subscribed, for {args.seconds:g} s. The `zenoh` layer "
        "cannot count what reaches it: its poses are those the publisher sent in its window "
        "(the `handoff` row shows how many arrive). The idle window's CPU, scaled to each "
        "window's length, is subtracted; the `node` layer's update thread idling at 100 Hz "
        "is not in it. The `inbound` and `node` layers count each pose and note its delay in "
        f"one wrapper call more per pose than a node makes. {_rounds(args.rounds)}"
    )
    parts = [intro, "", paths(windows)]
    for mode, figures in summary.items():
        parts += ["", f"A node in **{mode}** mode:", "", table(figures)]
    return "\n".join([*parts, "", delays(summary), "", verdict(summary)])


# ---------------------------------------------------------------- the command line


def _positive(kind: type) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        value = kind(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"must be > 0 (got {text})")
        return value

    return parse


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    numbers = [  # flag, type, default, what it sets
        ("--egos", int, 256, "egos whose poses the publisher sends"),
        ("--rate", float, 50.0, "poses per second of each ego [Hz]"),
        ("--seconds", float, 8.0, "length of each measured window [s]"),
        ("--rounds", int, 3, "times every window runs; the report gives the median"),
    ]
    for flag, kind, default, what in numbers:
        parser.add_argument(flag, type=_positive(kind), default=default,
                            help=f"{what} (default: %(default)s)")  # fmt: skip
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES),
                        help="session modes of the measured node (default: both)")  # fmt: skip
    parser.add_argument("--warmup", type=float, default=2.0,
                        help="wait after a subscriber joined, before measuring it [s] "
                        "(default: %(default)s)")  # fmt: skip
    parser.add_argument(
        "--json", type=Path, metavar="PATH", help="also write every window's raw figures to PATH"
    )
    parser.add_argument("--write", action="store_true",
                        help=f"write the section {TITLE!r} of docs/benchmarks.md; without it "
                        "the section's body is printed")  # fmt: skip
    args = parser.parse_args(argv)
    if args.warmup < 0:
        parser.error(f"--warmup must be >= 0 (got {args.warmup:g})")
    return args


def _without_json(argv: list[str] | None) -> list[str]:
    """The arguments that decide the figures: `--json PATH` names a local file, not a setting."""
    args = list(sys.argv[1:] if argv is None else argv)
    if "--json" in args:
        at = args.index("--json")
        del args[at : at + 2]
    return [a for a in args if not a.startswith("--json=")]


def main(argv: list[str] | None = None) -> int:
    run = RunInfo.start()  # first: the machine's load and speed before the run
    args = parse_args(argv)
    bench = Bench(args)
    try:
        bench.start()
        windows = run_rounds(bench, args)
    except BenchError as exc:
        print(f"bench_receive: {exc}", file=sys.stderr)
        return 1
    finally:
        bench.close()
    summary = summarise(windows, args.modes)
    if args.json:
        raw = {"windows": windows, "summary": {m: {k: asdict(f) for k, f in s.items()}
                                               for m, s in summary.items()}}  # fmt: skip
        args.json.write_text(json.dumps(raw, indent=1))
    body = section(summary, windows, args)
    if args.write:
        write_section(TITLE, body, command_line(_without_json(argv)), run)
    else:
        print(body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
