"""`carlaverse record`: every key of a session into an MCAP file, or `--recover` a killed one."""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

from carlaverse.cli.common import (
    add_fabric_args,
    attend,
    fabric_from_args,
    fail,
    reached_nothing,
    stop_on_signals,
    tell,
)
from carlaverse.cli.exit_codes import Exit
from carlaverse.cli.osi import add_options as add_osi_options
from carlaverse.cli.osi import check_options as check_osi_options
from carlaverse.cli.osi import export_beside as export_osi
from carlaverse.cli.record_lsl import LSL_ERRORS, add_lsl_arguments, prepare_lsl
from carlaverse.config import ConfigError
from carlaverse.keys import Keys, KeySpaceError
from carlaverse.recording.recorder import (
    DEFAULT_QUEUE_BYTES,
    DEFAULT_QUEUE_SIZE,
    Recorder,
    RecorderStats,
)
from carlaverse.recording.recover import recover
from carlaverse.recording.sink import DEFAULT_CHUNK_SIZE, McapSink, RecordingError
from carlaverse.study.lsl_session import describe as describe_lsl
from carlaverse.study.lsl_sink import SharedSink
from carlaverse.transport.session import FabricError, FabricUnreachable


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--session", help="session name to record (e.g. demo)")
    parser.add_argument("-o", "--output", required=True, type=Path, help="MCAP file to write")
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="stop after S seconds (default: until Ctrl-C / SIGTERM)",
    )
    parser.add_argument(
        "--recover",
        type=Path,
        metavar="IN.mcap",
        help="rewrite an unfinished recording (killed recorder) into -o, indexed",
    )
    parser.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")
    parser.add_argument(
        "--chunk-kib",
        type=int,
        default=DEFAULT_CHUNK_SIZE // 1024,
        help="chunk size [KiB]; a crash loses at most one chunk or 1 s",
    )
    parser.add_argument(
        "--queue-size",
        type=int,
        default=DEFAULT_QUEUE_SIZE,
        help="samples buffered for the writer before drops are counted",
    )
    parser.add_argument(
        "--queue-mib",
        type=int,
        default=DEFAULT_QUEUE_BYTES // 2**20,
        help="payload MiB buffered for the writer before drops are counted (bounds memory)",
    )
    parser.add_argument(
        "--progress-s",
        type=float,
        default=1.0,
        help="progress line interval on stderr [s]; 0 turns it off",
    )
    parser.add_argument(
        "--id",
        dest="node_id",
        default="recorder",
        help="identity in a --roster session (default recorder)",
    )
    osi = parser.add_argument_group("ASAM OSI ground truth (needs the osi extra)")
    osi.add_argument(
        "--osi",
        action="store_true",
        help="when the recording ends (or is recovered), also write its ground truth as an "
        "OSI trace, NAME.osi.mcap beside NAME.mcap (an OSI trace holds OSI messages only)",
    )
    add_osi_options(osi)
    add_lsl_arguments(parser)
    add_fabric_args(parser, session=False)
    parser.epilog = (
        "Exit 3 when no router or peer was reached for the whole run (nothing recorded "
        "because of the network), 1 when the file could not be written."
    )


def run(args: argparse.Namespace) -> int:
    try:
        if args.osi and (problem := check_osi_options(args)):  # before, not after, an hour
            return fail("record", problem)
        if args.recover:
            return _recover(args)
        if not args.session:
            return fail("record", "--session NAME is required (or --recover IN.mcap)")
        return _record(args)
    except (KeySpaceError, ConfigError) as exc:  # ConfigError: a --roster problem
        return fail("record", str(exc))
    except FabricError as exc:
        return fail("record", str(exc), Exit.FABRIC)
    except RecordingError as exc:
        return fail("record", str(exc), Exit.FAILED)
    except LSL_ERRORS as exc:  # pylsl missing, a --lsl stream not found: nothing written
        return fail("record", str(exc))


def _recover(args: argparse.Namespace) -> int:
    if not args.recover.is_file():
        return fail("record", f"--recover {args.recover}: no such recording")
    report = recover(args.recover, args.output, args.compression)
    state = "was complete" if report.complete else f"was cut short ({report.stopped_by})"
    tell(
        f"recovered {report.messages} messages on {report.channels} channels, "
        f"{report.attachments} attachments, {report.metadata} metadata records from "
        f"{args.recover} ({state}) into {args.output}"
    )
    return export_osi(args.output, args, "record") if args.osi else Exit.OK


def _record(args: argparse.Namespace) -> int:
    keys = Keys(args.session)
    lsl = prepare_lsl(args)  # the --lsl streams are found first, or nothing starts
    stop = stop_on_signals()  # the file is always finished with its indexes
    deadline = None if args.duration is None else time.monotonic() + args.duration
    fabric = fabric_from_args(args)
    try:
        # Like nodes and the viewer: one line naming what it waits for (router, authority),
        # retrying until then, and SIGINT/SIGTERM or --duration end the wait.
        session, notice = attend("record", fabric, keys, stop, deadline)
    except FabricUnreachable as exc:
        return fail("record", str(exc), stop.exit_code() if stop.is_set() else Exit.FABRIC)
    try:
        sink = (McapSink if lsl is None else SharedSink)(
            args.output,
            compression=args.compression,
            chunk_size=args.chunk_kib * 1024,
            monotonic=time.monotonic,
        )
        recorder = Recorder(
            session, keys, sink, queue_size=args.queue_size, queue_bytes=args.queue_mib * 2**20
        )
        recorder.start()
        if lsl is not None:
            lsl.start(session, keys, sink)
        # Said once subscribed: a script starting the session after it can wait for this line.
        tell(f"recording session {args.session} into {args.output}")
        _wait(recorder, stop, deadline, args.progress_s)
        if lsl is not None:
            tell(describe_lsl(lsl.stop()))  # before the recorder closes the file they write to
        stats = recorder.stop()
        unreached = reached_nothing(notice, fabric)
    finally:
        notice.close()
        session.close()
    if unreached:  # "recorded 0 messages" would read as a session where nothing happened
        code = stop.exit_code() if stop.is_set() else Exit.FABRIC
        return fail("record", f"{unreached}: nothing recorded into {args.output}", code)
    tell(f"recorded {_describe(stats)} into {args.output}")
    if stats.failure:
        return fail("record", f"RECORDING FAILED: {stats.failure}", Exit.FAILED)
    if args.osi:
        return export_osi(args.output, args, "record")
    return Exit.OK


def _wait(
    recorder: Recorder, stop: threading.Event, deadline: float | None, progress_s: float
) -> None:
    """Block until the deadline passes, SIGINT/SIGTERM arrives or the writer fails."""
    last = (time.monotonic(), 0)
    try:
        while not stop.is_set() and recorder.stats().failure == "":
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                return
            step = progress_s if progress_s > 0 else 0.5
            timeout = step if deadline is None else max(0.0, min(step, deadline - now))
            if stop.wait(timeout) or progress_s <= 0:
                continue
            last = _progress(recorder.stats(), last)
    except KeyboardInterrupt:  # only when signals could not be taken over (not main thread)
        return


def _progress(stats: RecorderStats, last: tuple[float, int]) -> tuple[float, int]:
    now = time.monotonic()
    rate = (stats.written - last[1]) / max(now - last[0], 1e-6)
    tell(f"recording: {_describe(stats)}, {rate:.0f} msg/s")
    return now, stats.written


def _describe(stats: RecorderStats) -> str:
    text = (
        f"{stats.written} messages, {stats.bytes_in / 1e6:.2f} MB on {stats.channels} keys, "
        f"{stats.attachments} attachments, {stats.dropped} dropped"
    )
    if stats.decode_errors:
        text += f", {stats.decode_errors} undecodable (kept raw)"
    if stats.rejected:
        why = ", ".join(f"{reason} {n}" for reason, n in stats.rejected_by.items())
        text += f", {stats.rejected} rejected ({why})"
    return text
