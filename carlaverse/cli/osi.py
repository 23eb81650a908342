"""`carlaverse osi REC.mcap -o OUT.mcap`: a recording's ground truth as an ASAM OSI trace."""

from __future__ import annotations

import argparse
from pathlib import Path

from carlaverse.cli.common import fail, tell
from carlaverse.cli.exit_codes import Exit

NAME = "osi"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Export a recording's ground truth as an ASAM OSI multi-channel trace (MCAP): one "
        "osi3.GroundTruth per tick on channel `ground_truth` with every ego and NPC (type, "
        "size, pose, velocity, acceleration, lights), the map's lanes and boundaries (first "
        "frame), every signal head's bulbs and the weather. Positions, angles and velocities "
        "are in the map frame, which is OSI's global frame; timestamps are session time."
    )
    parser.add_argument("recording", type=Path, metavar="REC.mcap", help="a session recording")
    parser.add_argument("-o", "--output", type=Path, default=None, metavar="OUT.mcap",
                        help="OSI trace to write (default: REC.osi.mcap beside it)")  # fmt: skip
    add_options(parser)


def add_options(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """The export's flags, shared with `carlaverse record --osi`."""
    parser.add_argument("--osi-rate", type=float, default=20.0, metavar="HZ",
                        help="ground truths per second of session time (default 20)")  # fmt: skip
    parser.add_argument("--osi-host", default=None, metavar="ID",
                        help="the ego that is the host vehicle (default: the first)")  # fmt: skip
    parser.add_argument("--osi-map-every-frame", action="store_true",
                        help="lanes and boundaries in every frame, not only the first")  # fmt: skip


def check_options(args: argparse.Namespace) -> str:
    """What is wrong with the export's flags ("" if nothing); imports the osi3 bindings, so a
    missing extra is reported before any work (`carlaverse.cli.main` names its install)."""
    import osi3  # noqa: F401

    return "" if args.osi_rate > 0 else f"--osi-rate must be > 0, got {args.osi_rate}"


def export_beside(recording: Path, args: argparse.Namespace, command: str) -> int:
    """Export into NAME.osi.mcap beside NAME.mcap."""
    from carlaverse.recording.osi_trace import sibling_path

    return export(recording, sibling_path(recording), args, command)


def export(recording: Path, output: Path, args: argparse.Namespace, command: str = NAME) -> int:
    """Write the trace; one line on stderr saying what it holds, or why it failed."""
    from carlaverse.recording.osi_ground_truth import Options
    from carlaverse.recording.osi_trace import export as export_trace
    from carlaverse.recording.sink import RecordingError

    if problem := check_options(args):
        return fail(command, problem)
    options = Options(args.osi_rate, host=args.osi_host, map_every_frame=args.osi_map_every_frame)
    try:
        report = export_trace(recording, output, options)
    except RecordingError as exc:
        return fail(command, str(exc), Exit.FAILED)
    tell(f"wrote {report.frames} OSI ground truths ({report.moving_objects} moving objects, "
         f"{report.lanes} lanes, {report.traffic_lights} signal bulbs) into {output}")  # fmt: skip
    return Exit.OK


def run(args: argparse.Namespace) -> int:
    from carlaverse.recording.osi_trace import sibling_path

    if not args.recording.is_file():
        return fail(NAME, f"{args.recording}: no such recording")
    output = args.output or sibling_path(args.recording)
    if output.suffix != ".mcap":  # the OSI trace file spec: multi-channel traces are .mcap
        return fail(NAME, f"-o {output}: an OSI multi-channel trace file ends in .mcap")
    if output.resolve() == args.recording.resolve():
        return fail(NAME, f"-o {output} is the recording itself: name another file")
    return export(args.recording, output, args)
