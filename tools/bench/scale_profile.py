"""Where the authority's time goes: a py-spy recording split into the parts of its work.

`bench_scale.py --profile` records the authority with py-spy (raw format: one line per
distinct stack, `frame;frame;…;frame count`, root first, a frame being
`function (file:line)`). Each stack is given to the first part whose function it finds,
walking from the leaf towards the root, so SUMO's own step inside `SumoEngine.step` counts
as SUMO's, and the rest of `SumoEngine.step` as ours. Shares are of one core: samples over
(rate × seconds), so parts add up to the Python threads' CPU, all of them together.

py-spy records with `--idle`, every Python thread in every sample, and this module drops
the samples that sit in a known wait (IDLE_LEAVES). py-spy's own idle filter cannot be
trusted beside Zenoh's native threads: at N = 256 it kept the tick thread only while it sat
in its wait between ticks (87 samples in 5 s) and dropped nearly all of the tick's work (2
samples), which made the split read 0% for pose intake and SUMO's hand-over.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

# py-spy's --rate, set explicitly by the benchmark: not a divisor of the 50 Hz tick's
# period, so the samples walk through the tick rather than keep one phase of it.
SAMPLE_RATE_HZ = 97


# (part, [(function name, file name)]): a frame matches when both match.
PARTS: list[tuple[str, list[tuple[str, str]]]] = [
    ("SUMO's own step (libsumo simulationStep)", [("simulationStep", ""), ("step", "libsumo.py")]),
    ("NPC read-back from SUMO", [("read", "sumo_reader.py")]),
    ("NPC demand top-up", [("_top_up", "sumo_engine.py")]),
    ("egos carried in SUMO (moveToXY)", [("place", "sumo_egos.py"), ("place_egos", "")]),
    ("pose intake (callback, decode, roster)",
     [("_on_pose", "service.py"), ("_apply_poses", "service.py"), ("drain", "pose_intake.py")]),
    ("egos dead-reckoned to the tick", [("egos_at", "actors.py"), ("ego_columns", "actors.py")]),
    ("collision matrix", [("build_actors", "actors.py"), ("step", "collisions.py")]),
    ("triggers", [("tick", "triggers.py")]),
    ("audio scenes", [("tick", "sound_publisher.py")]),
    ("NPC batches, lights, weather", [("_publish_world", "traffic_domain.py")]),
    ("rest of the tick", [("tick", "service.py")]),
    ("queries and presence (callbacks)",
     [("_on_join", ""), ("_on_clock", ""), ("_on_presence", ""), ("_on_state", ""),
      ("_on_snapshot", ""), ("_on_leave", "")]),
]  # fmt: skip
OTHER = "other (interpreter, Zenoh threads, idle loop)"
# SUMO runs in a child of the authority (traffic.sumo_process), recorded with --subprocesses:
# its stacks are split the same way, under this prefix, so they are not read as the tick's.
SUMO_PROCESS = "SUMO's own process, beside the tick: "
SUMO_PROCESS_ROOTS = {("_serve", "sumo_process.py"), ("main", "sumo_process.py")}
# Frames under every stack of a process or thread: on top of the list, telling nothing.
BOOTSTRAP = (
    "<module> ",
    "_run_",
    "spawn_main ",
    "_main ",
    "Thread._bootstrap",
    "Thread.run ",
    "BaseProcess._bootstrap",
    "BaseProcess.run ",
    "main (carlaverse/traffic/sumo",
)


# (function, file name) of a leaf frame that blocks: a sample there is a thread waiting.
IDLE_LEAVES = {
    ("wait", "threading.py"),  # the tick's wait for its next period, the digest relay's
    ("_recv", "connection.py"),  # a multiprocessing pipe: the control pipe, SUMO's requests
    ("_poll", "connection.py"),
    ("select", "selectors.py"),
}


def is_idle(stack: list[str]) -> bool:
    """A thread waiting, or one with no Python frame of its own (Zenoh's native threads
    between callbacks: their own work is Rust, outside a Python profile)."""
    if all(frame.startswith(BOOTSTRAP) for frame in stack):
        return True
    return _frame_parts(stack[-1]) in IDLE_LEAVES


def _frame_parts(frame: str) -> tuple[str, str]:
    """(function, file name) of a py-spy frame `Class.function (path/file.py:line)`."""
    name, _, where = frame.partition(" (")
    return name.rsplit(".", 1)[-1], where.rsplit(":", 1)[0].rsplit("/", 1)[-1]


def part_of(stack: list[str]) -> str:
    frames = [_frame_parts(frame) for frame in stack]
    prefix = SUMO_PROCESS if any(f in SUMO_PROCESS_ROOTS for f in frames) else ""
    for name, file in reversed(frames):
        for part, patterns in PARTS:
            if any(name == n and (not f or file == f) for n, f in patterns):
                return prefix + part
    return prefix + OTHER


def stacks(raw: Path) -> Iterator[tuple[list[str], int]]:
    """(frames root first, samples) of each line. With --subprocesses py-spy puts a frame
    `process PID:"command line"` at the root, one per process down to the sampled one, whose
    command line may hold `;`: dropped."""
    for line in raw.read_text().splitlines():
        stack, _, count = line.rpartition(" ")
        while stack.startswith("process "):
            stack = stack[stack.find('";', stack.find('"') + 1) + 2 :]
        if stack and count.isdigit():
            yield stack.split(";"), int(count)


def busy_stacks(raw: Path) -> Iterator[tuple[list[str], int]]:
    """The stacks of `raw` that are not idle."""
    return ((frames, n) for frames, n in stacks(raw) if not is_idle(frames))


def split(raw: Path, seconds: float) -> dict[str, float]:
    """Share of one core per part (0.25 = a quarter of a core), largest first."""
    samples: dict[str, int] = {}
    for frames, count in busy_stacks(raw):
        part = part_of(frames)
        samples[part] = samples.get(part, 0) + count
    total = SAMPLE_RATE_HZ * seconds
    return dict(sorted(((p, n / total) for p, n in samples.items()), key=lambda kv: -kv[1]))


def save(shares: dict[str, float], egos: int, label: str, out: Path) -> None:
    out.write_text(json.dumps({"egos": egos, "label": label, "shares": shares}, indent=1))


def table(after: dict[str, float], before: dict | None) -> str:
    """Markdown: share of a core per part, this run beside a recorded earlier one."""
    if before is None:
        rows = ["| part of the authority's work | share of one core |", "|---|---|"]
        rows += [f"| {part} | {share:.1%} |" for part, share in after.items()]
        return "\n".join(rows)
    old = before["shares"]
    rows = [
        f"| part of the authority's work | before ({before['label']}) | after (this run) |",
        "|---|---|---|",
    ]
    for part in list(dict.fromkeys([*old, *after])):
        rows.append(f"| {part} | {old.get(part, 0.0):.1%} | {after.get(part, 0.0):.1%} |")
    rows.append(f"| total | {sum(old.values()):.1%} | {sum(after.values()):.1%} |")
    return "\n".join(rows)


def top_functions(raw: Path, count: int = 15) -> list[tuple[str, float]]:
    """Functions by the share of samples they were on the stack in (inclusive)."""
    totals: dict[str, int] = {}
    samples = 0
    for frames, n in busy_stacks(raw):
        samples += n
        for frame in set(frames):
            if not frame.startswith(BOOTSTRAP):
                totals[frame] = totals.get(frame, 0) + n
    ranked = sorted(totals.items(), key=lambda kv: -kv[1])[:count]
    return [(frame, n / max(samples, 1)) for frame, n in ranked]


def text(raw: Path, egos: int, seconds: float, before: dict | None) -> str:
    """The profile's section text: the split beside `before`, then the top functions."""
    if not raw.exists():
        return ""
    shares = split(raw, seconds)
    rows = ["| function (file:line) | share of samples |", "|---|---|"]
    rows += [f"| `{frame}` | {share:.0%} |" for frame, share in top_functions(raw)]
    compared = (
        f" beside the same split recorded by this script before ({before['label']}, "
        f"N = {before['egos']})"
        if before
        else ""
    )
    return (
        f"Where the authority's time went at N = {egos} in a window like the session one, after "
        f"the measured ones (py-spy at "
        f"{SAMPLE_RATE_HZ} Hz with --idle, every Python thread: the tick, Zenoh's callbacks, "
        f"and its SUMO process; a sample in a wait is dropped, and Zenoh's native threads, "
        f"which have no Python frames, are outside the split), split into the parts of its "
        f"work as shares of one core{compared}:\n\n"
        + table(shares, before)
        + "\n\nTop functions (inclusive, share of samples):\n\n"
        + "\n".join(rows)
    )


def main(argv: list[str] | None = None) -> int:
    """Split a raw recording again (e.g. after a new part was named) and save it."""
    import argparse

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("raw", type=Path)
    parser.add_argument("--seconds", type=float, required=True, help="the recording's length")
    parser.add_argument("--egos", type=int, required=True)
    parser.add_argument("--label", required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    shares = split(args.raw, args.seconds)
    save(shares, args.egos, args.label, args.out)
    print(table(shares, None))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
