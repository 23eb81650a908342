"""`carlaverse render SESSION|FILE.mcap --camera NODE_ID|free --out F.png|F.mp4`.

Renders offscreen, through the same world view a live node uses, either a recorded moment
(`--at S` seconds into the recording, or `--at-session T` on the session clock) or clip of a
recording, or a live session as it is now (a still) or from now on (a clip, in real time).
The camera rides with a node (`--camera car-1`, from its head position in the rig), chases
it from behind and above (`--camera car-1 --chase`, `render.chase`), or looks over the map
(`--camera free`; a world with neither a map nor actors is an error, not an empty picture).

    carlaverse render lab.mcap --camera car-1 --at 12.5 --out car1.png
    carlaverse render lab.mcap --camera car-1 --chase --at 20 --duration 10 --out chase.mp4
    carlaverse render demo --connect tcp/127.0.0.1:7447 --out now.png
    carlaverse render demo --connect tcp/127.0.0.1:7447 --out next5s.mp4 --duration 5

A live session is observed like `join observer` does (`render.live.LiveWorld`): the render
waits for admission, the authority's map answer and the first actors, then draws.
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from carlaverse.cli.common import (
    StopSignal,
    add_fabric_args,
    attend,
    fabric_from_args,
    fail,
    print_json,
    say,
    stop_on_signals,
)
from carlaverse.cli.exit_codes import Exit

DEFAULT_RIG = "rigs/rig-desktop"
FREE = "free"
JOIN_TIMEOUT_S = 30.0  # [s] for a live session's world to arrive


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "source",
        metavar="SESSION|FILE.mcap",
        help="a live session's name, or a carlaverse recording",
    )
    parser.add_argument("--camera", default=FREE, help="node id to ride with, or 'free'")
    parser.add_argument(
        "--chase",
        action="store_true",
        help="with --camera NODE_ID: follow it from 6 m behind and 2.5 m above, looking at it "
        "(the camera swings round a turn with a 0.5 s lag)",
    )
    when = parser.add_mutually_exclusive_group()
    when.add_argument(
        "--at",
        type=float,
        metavar="S",
        help="seconds from the recording's start (its first sample); default: the first pose. "
        "Outside the recording is an error naming its range",
    )
    when.add_argument(
        "--at-session",
        type=float,
        metavar="T",
        help="session time [s] of the recording's moment instead (the clock poses carry)",
    )
    parser.add_argument("--out", type=Path, required=True, help="F.png (a still) or F.mp4 (a clip)")
    parser.add_argument("--duration", type=float, default=5.0, help="clip length [s] (MP4)")
    parser.add_argument("--fps", type=float, default=30.0, help="clip frame rate (MP4)")
    parser.add_argument("--rig", default=DEFAULT_RIG, help="render config with the camera rig")
    parser.add_argument("--width", type=int, help="override the rig's resolution (simple rigs)")
    parser.add_argument("--height", type=int, help="override the rig's resolution (simple rigs)")
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object: out, frames, the session time of the first frame (t) and "
        "of the recording's start (recording_start, null when live)",
    )
    live = parser.add_argument_group("live session")
    live.add_argument(
        "--join-timeout",
        type=float,
        default=JOIN_TIMEOUT_S,
        metavar="S",
        help=f"how long to wait for the session's world to arrive (default {JOIN_TIMEOUT_S:g})",
    )
    live.add_argument(
        "--id",
        dest="node_id",
        default=f"render-{os.getpid()}",
        help="this observer's id (a --roster session: its certificate's)",
    )
    add_fabric_args(parser, session=False)


def is_recording(source: str) -> bool:
    """A recording is an existing file or names an .mcap; anything else is a session."""
    return Path(source).is_file() or source.lower().endswith(".mcap")


def run(args: argparse.Namespace) -> int:
    problem = _usage_problem(args)
    if problem:
        return fail("render", problem)
    try:
        from carlaverse.render.graphics import RenderError
    except ImportError as exc:
        return fail("render", f"rendering needs Panda3D ({exc}): pip install 'carlaverse[render]'")
    from carlaverse.config import ConfigError
    from carlaverse.recording.sink import RecordingError
    from carlaverse.render.live import WorldMissing
    from carlaverse.render.renderer import FollowError
    from carlaverse.transport.session import FabricError, FabricUnreachable

    live = not is_recording(args.source)
    stop = stop_on_signals() if live else threading.Event()  # Ctrl-C leaves a session cleanly
    render = _render_live if live else _render_recording
    try:
        config = _config(args)  # a bad rig is said before any wait for a session
        shown = render(args, config, stop)
    except (FabricUnreachable, WorldMissing) as exc:  # no router, authority or world in time
        waited = f" (waited --join-timeout {args.join_timeout:g} s)"
        return fail("render", f"{exc}{waited}",
                    stop.exit_code() if isinstance(stop, StopSignal) and stop.is_set()
                    else Exit.NOT_ADMITTED)  # fmt: skip
    except FabricError as exc:
        return fail("render", str(exc), Exit.FABRIC)
    except ConfigError as exc:  # a rig file that does not decode: nothing was drawn
        return fail("render", str(exc), Exit.USAGE)
    except (RecordingError, RenderError, FollowError, ValueError) as exc:
        return fail("render", str(exc), Exit.FAILED)
    if args.json:
        print_json({"out": str(args.out), "frames": shown.frames, "t": shown.first_t,
                    "recording_start": shown.recording_start, "at": shown.at})  # fmt: skip
    else:
        at = "" if shown.at is None else f" from {shown.at:.2f} s after the recording's start"
        print(f"render: {shown.frames} frame(s){at} -> {args.out}")
    return Exit.OK


@dataclass
class Shown:
    """What a render drew: how many frames, and when the first one is on the session clock."""

    frames: int = 0
    first_t: float | None = None  # [s] session time of frame 0
    recording_start: float | None = None  # [s] session time of the recording's first sample

    @property
    def at(self) -> float | None:
        """[s] frame 0 from the recording's start (None live): what --at takes back."""
        if self.first_t is None or self.recording_start is None:
            return None
        return self.first_t - self.recording_start


def _usage_problem(args: argparse.Namespace) -> str:
    """What is wrong with the command line, in one line ('' when nothing)."""
    if args.out.suffix.lower() not in (".png", ".mp4"):
        return f"--out {args.out}: give a .png (still) or .mp4 (clip) file"
    if args.duration <= 0 or args.fps <= 0:
        return "--duration and --fps must be > 0"
    if args.chase and args.camera == FREE:
        return "--chase follows a node: give --camera NODE_ID"
    if is_recording(args.source):
        if not Path(args.source).is_file():
            return f"{args.source}: no such recording"
        if args.connect or args.listen or args.roster:
            return "--connect, --listen and --roster are for a live session, not a recording"
        return _moment_problem(args)
    if args.at is not None or args.at_session is not None:
        flag = "--at" if args.at is not None else "--at-session"
        return f"{flag} is for recordings; a live session ({args.source!r}) renders as it is now"
    if args.join_timeout <= 0:
        return f"--join-timeout {args.join_timeout}: give seconds > 0"
    return _fabric_problem(args)


def _moment_problem(args: argparse.Namespace) -> str:
    """An --at or --at-session outside the recording, naming its range ('' when inside)."""
    from carlaverse.recording.sink import RecordingError
    from carlaverse.recording.timeline import OutOfRange

    try:
        _start_time(args)
    except OutOfRange as exc:
        return str(exc)
    except RecordingError:
        return ""  # a file that cannot be read is said when the render reads it
    return ""


def _start_time(args: argparse.Namespace) -> float:
    """Session time [s] of the first frame: --at from the recording's start, --at-session on
    the session clock, else the first pose. OutOfRange outside the recording."""
    from carlaverse.recording.timeline import first_pose_time, recording_span

    if args.at is not None:
        return recording_span(args.source).session_time(args.at, "--at")
    if args.at_session is not None:
        return recording_span(args.source).session_time(
            args.at_session, "--at-session", session=True
        )
    return first_pose_time(args.source)


def _fabric_problem(args: argparse.Namespace) -> str:
    from carlaverse.config import ConfigError
    from carlaverse.keys import KeySpaceError, check_token
    from carlaverse.transport.session import FabricError, build_config

    try:  # a bad session name, endpoint or roster entry is a usage error
        check_token(args.source, "session name")
        check_token(args.node_id, "--id")
        build_config(fabric_from_args(args))
    except (KeySpaceError, FabricError, ConfigError) as exc:
        return str(exc)
    return ""


def _config(args: argparse.Namespace):  # -> RenderConfig
    import msgspec

    from carlaverse.config import load_config
    from carlaverse.render.rig import RenderConfig, Resolution, SimpleRig

    config = load_config(args.rig, RenderConfig)
    config = msgspec.structs.replace(config, output="offscreen")
    if args.width or args.height:
        if not isinstance(config.camera, SimpleRig):
            raise ValueError("--width/--height apply to simple rigs; set sizes in the rig file")
        res = config.camera.resolution
        size = Resolution(width=args.width or res.width, height=args.height or res.height)
        config = msgspec.structs.replace(
            config, camera=msgspec.structs.replace(config.camera, resolution=size)
        )
    return config


def _render_recording(args: argparse.Namespace, config: Any, stop: threading.Event) -> Shown:
    from carlaverse.recording.reading import recorded_map
    from carlaverse.recording.timeline import recording_span, recording_start_time
    from carlaverse.render.recording import RecordedWorld
    from carlaverse.render.renderer import Renderer

    world = RecordedWorld(args.source)
    origin = recording_start_time(args.source)
    shown = Shown(recording_start=origin)
    start = _start_time(args)
    if args.out.suffix.lower() == ".mp4":
        span = recording_span(args.source)
        past_s = start + args.duration - span.end
        if past_s > 0:
            say("render")(f"the clip runs {past_s:.1f} s past the recording's end "
                          f"({span.valid()}): nothing was recorded for its last "
                          "frames")  # fmt: skip
    road_map = recorded_map(args.source)
    first = world.frame(start)
    if args.camera == FREE and road_map is None and not first.actors:
        raise ValueError(
            f"{args.source} has no map and no actors at {start - origin:.2f} s "
            f"from start (session time {start:.3f} s): nothing for "
            "--camera free to show (was anything recorded? try a later --at)"
        )
    with Renderer(config, road_map) as renderer:  # the world reads forward only
        shown.frames = _capture(
            args, renderer, lambda k: first if k == 0 else world.frame(start + k / args.fps), stop
        )
    shown.first_t = first.t
    if world.bad_samples:  # a damaged or foreign sample is skipped, not drawn: say how many
        say("render")(f"{world.bad_samples} recorded samples could not be read and were skipped")
    return shown


def _render_live(args: argparse.Namespace, config: Any, stop: threading.Event) -> Shown:
    from carlaverse.keys import Keys
    from carlaverse.transport.node_client import NodeSettings

    deadline = time.monotonic() + args.join_timeout
    fabric = fabric_from_args(args)
    session, notice = attend("render", fabric, Keys(args.source), stop, deadline)
    try:
        node = NodeSettings(node_id=args.node_id, session=args.source)
        return _draw_live(args, config, session, node, deadline, stop)
    finally:
        notice.close()
        session.close()


def _draw_live(args: argparse.Namespace, config: Any, session: Any, node: Any,
               deadline: float, stop: threading.Event) -> Shown:  # fmt: skip
    from carlaverse.render.live import LiveWorld
    from carlaverse.render.renderer import Renderer

    world = LiveWorld(session, node, own=None).start()
    try:
        road_map = world.wait_for_map(deadline, stop)
        follow = None if args.camera == FREE else args.camera
        world.wait_for_actors(deadline, stop, actor_id=follow)
        pace = RealTime(world.frame, args.fps)
        with Renderer(config, road_map) as renderer:
            frames = _capture(args, renderer, pace, stop)
        if pace.repeated:
            slow = "drawing is slower than --fps; the clip keeps the session's pace"
            say("render")(f"{pace.repeated} of {frames} frames repeat the one before: {slow}")
        return Shown(frames, pace.first_t)
    finally:
        world.close()


class RealTime:
    """Live frames for a clip: frame k is the session `k / fps` after the first. A frame
    that is already a period late is skipped (None: the clip repeats the last image), so
    the clip plays at the session's pace even when drawing is slower than `fps`."""

    def __init__(self, frame: Callable[[], Any], fps: float) -> None:
        self.frame = frame
        self.period_s = 1.0 / fps
        self.start = time.monotonic()
        self.repeated = 0
        self.first_t: float | None = None  # [s] session time of frame 0

    def __call__(self, k: int) -> Any:
        late_s = time.monotonic() - (self.start + k * self.period_s)
        if k > 0 and late_s > self.period_s:
            self.repeated += 1
            return None
        time.sleep(max(0.0, -late_s))
        frame = self.frame()
        if k == 0:
            self.first_t = frame.t
        return frame


def _capture(args: argparse.Namespace, renderer: Any, frame_at: Callable[[int], Any],
             stop: threading.Event) -> int:  # fmt: skip
    """Draw frame 0 into a PNG, or frames 0.. of `--duration` into an MP4; returns how many
    frames were written. `frame_at(k)` None repeats the previous image."""
    from carlaverse.render.video import ClipWriter, save_png

    draw = _drawer(args, renderer)
    if args.out.suffix.lower() == ".png":
        draw(frame_at(0))
        save_png(args.out, renderer.images()[0])
        return 1
    w, h = renderer.layout.outputs[0]
    clip = ClipWriter(args.out, w, h, args.fps)
    try:
        for k in range(max(1, int(args.duration * args.fps))):
            if stop.is_set():
                break  # Ctrl-C: the clip so far is a valid file
            frame = frame_at(k)
            if frame is not None:
                draw(frame)
            clip.add(renderer.images()[0])
    finally:
        clip.close()
    return clip.frames


def _drawer(args: argparse.Namespace, renderer: Any) -> Callable[[Any], None]:
    """How a frame is drawn: from the followed node's head, chasing it, or over the map."""
    if args.camera == FREE:
        return lambda frame: renderer.draw(frame)
    if not args.chase:
        return lambda frame: renderer.draw(frame, follow=args.camera)
    from carlaverse.render.chase import ChaseCamera
    from carlaverse.render.renderer import FollowError

    chase = ChaseCamera(renderer.layout.head)

    def draw(frame: Any) -> None:
        actor = frame.actor(args.camera)
        if actor is None:  # the same one-line error as riding with it
            raise FollowError(f"no actor {args.camera!r} at t = {frame.t:.3f} s to chase")
        renderer.draw(frame, eye=chase.eye(actor, frame.t))

    return draw
