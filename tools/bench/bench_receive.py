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
  nobody drains: parse the key, check the pose's bytes, stamp with the session clock, queue.
- node: as inbound, plus a thread applying the inbox (`WorldView.update`) every 10 ms as a
  node's 100 Hz loop does; that thread's own CPU per pose is reported apart as well.

Then `zenoh`, `node` again with every pose put express (a frame of its own), and `zenoh`,
`handoff`, `node` with the poses put as the authority's pose digest relays them (`+digest`:
a tenth of the egos' poses to a sample, every 2 ms at 50 Hz, as the relay's shipped period
gathers them), the node trusting the publisher as its authority.

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
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from benchdoc import RunInfo, command_line, write_section
from peers.transport import free_ports, wait_for_port
from receive_children import IDLE, publisher_main, subscriber_main
from receive_report import DIGEST_LAYERS, EXPRESS_LAYERS, LAYERS, poses, section, summarise

TITLE = "Receive cost per pose, layer by layer"
MODES = ("peer", "client")
JOIN_S = 60.0  # [s] for a child to open its session and subscribe
REPLY_S = 30.0  # [s] for a child to answer a command
QUIT_S = 15.0  # [s] for a child or the router to end when asked


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
        (self.port,) = free_ports(1)
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.router: subprocess.Popen[bytes] | None = None
        self.publisher: Child | None = None
        self.publisher_id = ""  # its session's id: the digest layers trust it as authority

    def start(self) -> None:
        cli = [sys.executable, "-m", "carlaverse", "router", "--listen", self.endpoint]
        quiet = subprocess.DEVNULL  # its "listening" line would land in the printed body
        self.router = subprocess.Popen(cli, stdout=quiet, stderr=quiet)
        _wait_listening(self.router, self.port, JOIN_S)
        self.publisher = self._spawn("publisher", publisher_main, self.args.egos, self.args.rate)
        self.publisher_id = self.publisher.reply(JOIN_S)

    def sending(self, how: str) -> None:
        """`publish`, `publish-express`, `publish-digest` or `pause`."""
        assert self.publisher is not None
        self.publisher.ask(how)

    def window(self, mode: str, layer: str) -> dict[str, Any]:
        """One subscriber process of `layer`: joined, warmed up, measured, gone."""
        assert self.publisher is not None
        child = self._spawn(f"subscriber {mode}/{layer}", subscriber_main, mode, layer,
                            self.args.egos, self.publisher_id)  # fmt: skip
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


def _wait_listening(router: subprocess.Popen[bytes], port: int, timeout_s: float) -> None:
    """Until the router accepts connections; fails at once, naming why, if it exits first."""
    deadline = time.monotonic() + timeout_s
    while not wait_for_port(port, 0.5):
        if router.poll() is not None:
            raise BenchError(f"the router exited with code {router.returncode} before listening")
        if time.monotonic() > deadline:
            raise BenchError(f"the router did not listen on port {port} within {timeout_s:g} s")


def run_rounds(bench: Bench, args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every mode's idle window (publisher paused), then every (mode, layer), per round."""
    windows = []
    for r in range(args.rounds):
        for how, layers in (("pause", [IDLE]), ("publish", LAYERS),
                            ("publish-express", EXPRESS_LAYERS),
                            ("publish-digest", DIGEST_LAYERS)):  # fmt: skip
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
