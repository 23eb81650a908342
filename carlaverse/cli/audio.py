"""`carlaverse audio render FILE.mcap --listener ID --out F.wav`: a recording's spatial audio
for one listener, offline, as 16-bit multi-channel WAV.

    carlaverse audio render lab.mcap --listener car-1 --out car-1.wav                # headphones
    carlaverse audio render lab.mcap --listener car-1 --out car-1.wav --layout 5.1
    carlaverse audio render lab.mcap --listener car-1 --out c.wav --config ring8-lab.yaml
    carlaverse audio render lab.mcap --listener car-1 --out near-miss.wav --at 12 --duration 5

Times are seconds from the recording's start, as `render --at` and the analysis report give
them (`--at-session` takes the session clock instead); a time outside the recording is an
error naming its range.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TextIO

import msgspec

from carlaverse.cli.common import Companion, fail, json_stdout, print_json

PROGRESS_EVERY_S = 2.0  # [s] of wall time between progress lines on long renders


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=["render"],
                        help="render: a recording's audio for one listener")  # fmt: skip
    render = parser
    render.add_argument("recording", type=Path, help="a carlaverse recording (FILE.mcap)")
    render.add_argument("--listener", required=True, metavar="ID", help="node id whose ears")
    render.add_argument("--out", type=Path, required=True, help="the WAV file to write")
    render.add_argument("--layout", help="binaural (HRTF), stereo, quad, 5.1 or ringN, N from "
                        "3 to 64 (default: the config's, else binaural)")  # fmt: skip
    render.add_argument("--config", help="audio config YAML (path or shipped name, e.g. "
                        "audio/headphones)")  # fmt: skip
    when = render.add_mutually_exclusive_group()
    when.add_argument("--at", type=float, metavar="S",
                      help="start S seconds from the recording's start (default: the first "
                      "scene)")  # fmt: skip
    when.add_argument("--at-session", type=float, metavar="T",
                      help="start at session time T [s] instead")  # fmt: skip
    render.add_argument("--duration", type=float, metavar="S",
                        help="render S seconds (default: until the last scene has "
                        "faded)")  # fmt: skip
    render.add_argument("--json", action="store_true", help="print a summary object at exit")


def run(args: argparse.Namespace) -> int:
    with json_stdout(args.json) as out:
        return _run(args, out)


def _run(args: argparse.Namespace, out: TextIO) -> int:
    from carlaverse.audio.config import LAYOUT_PATTERN, LAYOUTS_IN_WORDS, AudioConfig
    from carlaverse.audio.hrtf import HrtfError
    from carlaverse.audio.offline import NothingToRender, render_recording
    from carlaverse.config import ConfigError, load_config
    from carlaverse.recording.sink import RecordingError
    from carlaverse.recording.timeline import OutOfRange, recording_start_time

    try:
        config = load_config(args.config, AudioConfig) if args.config else AudioConfig()
        if args.layout and not re.match(LAYOUT_PATTERN, args.layout):
            return fail("audio", f"--layout {args.layout!r} is not a layout: use "
                        f"{LAYOUTS_IN_WORDS}")  # fmt: skip
        if args.layout:
            config = msgspec.convert({**msgspec.to_builtins(config), "layout": args.layout},
                                     AudioConfig)  # fmt: skip
        if not args.recording.is_file():
            return fail("audio", f"{args.recording}: no such recording")
        if args.duration is not None and not args.duration > 0:
            return fail("audio", f"--duration {args.duration:g}: give seconds > 0")
        origin = recording_start_time(args.recording)
        summary = render_recording(args.recording, args.listener, args.out, config,
                                   _progress(origin), start=_start(args),
                                   duration=args.duration)  # fmt: skip
    except (ConfigError, NothingToRender, HrtfError, RecordingError, OSError,
            OutOfRange) as exc:  # fmt: skip
        return fail("audio", str(exc))
    if args.json:
        print_json(summary, out)
    else:
        print(f"{summary.out}: {summary.seconds:.1f} s from {summary.at:.2f} s after the "
              f"recording's start, {summary.channels} channels ({summary.layout}) for "
              f"{summary.listener} from {summary.scenes} scenes", file=sys.stderr)  # fmt: skip
    return 0


def _start(args: argparse.Namespace) -> float | None:
    """Session time [s] to start at (None: the first scene); OutOfRange outside the
    recording."""
    from carlaverse.recording.timeline import recording_span

    if args.at is not None:
        return recording_span(args.recording).session_time(args.at, "--at")
    if args.at_session is not None:
        span = recording_span(args.recording)
        return span.session_time(args.at_session, "--at-session", session=True)
    return None


def _progress(origin: float) -> Callable[[float, float], None]:
    """Prints the start (0 %), the end (100 %) and, in between, a line every few seconds;
    each says where the render is, in seconds from the recording's start (`origin`)."""
    last = [time.monotonic()]

    def report(fraction: float, t: float) -> None:
        if fraction in (0.0, 1.0) or time.monotonic() - last[0] >= PROGRESS_EVERY_S:
            last[0] = time.monotonic()
            print(f"carlaverse audio: {fraction:5.1%} rendered (at {t - origin:.1f} s from "
                  "start)", file=sys.stderr, flush=True)  # fmt: skip

    return report


# ---------------------------------------------------------------- `carlaverse join … --audio`


def add_audio_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--audio", metavar="CONFIG",
        help="play what the node hears, in a process of its own (audio config: path or "
        "shipped name, e.g. audio/headphones; audio/headless plays to a simulated device)",
    )  # fmt: skip


@contextlib.contextmanager
def node_audio(args: argparse.Namespace, node: Any, node_id: str) -> Iterator[Companion]:
    """Run the node's audio (when --audio) for the duration of the block; ConfigError (one
    line) when its config is wrong or its output cannot open. The node's client feeds it
    (`running` is the `node_runtime.AudioFeed` to give `run_node`)."""
    audio = Companion("audio")
    if args.audio:
        audio.running = _start_audio(args.audio, node, node_id)
    try:
        yield audio
    finally:
        if audio.running is not None:
            from carlaverse.audio.process import audio_report

            audio.report = audio_report(audio.running.close())
            if not args.json:
                print(_audio_line(audio.report), file=sys.stderr)


def _start_audio(name: str, node: Any, node_id: str) -> Any:
    from carlaverse.audio.config import AudioConfig
    from carlaverse.audio.ears import BlockSpec
    from carlaverse.audio.output import OutputError
    from carlaverse.audio.process import AudioProcess, AudioSpec
    from carlaverse.config import ConfigError, load_config

    config = load_config(name, AudioConfig)
    own = node.own_pose_block() if hasattr(node, "own_pose_block") else None
    block = BlockSpec(own.name, own.dtype) if own is not None else None
    try:
        return AudioProcess(AudioSpec(node_id, config, block)).start()
    except OutputError as exc:
        raise ConfigError("--audio", str(exc)) from exc


def _audio_line(report: dict[str, Any]) -> str:
    if report.get("error"):
        return f"carlaverse join: audio stopped: {report['error']}"
    return (
        f"carlaverse join: audio ({report['layout']} on {report['device']}): "
        f"{report['blocks']} blocks, {report['underruns']} underruns, {report['scenes']} scenes, "
        f"update-to-ear latency p50 {report['latency_ms_p50']} ms"
    )
