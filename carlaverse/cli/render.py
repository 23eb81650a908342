"""`carlaverse render SESSION|FILE.mcap --camera NODE_ID|free --out F.png|F.mp4`.

Renders offscreen, through the same world view a live node uses, either a recorded moment
(`--at T`) or clip of a recording, or a live session as it is now (a still) or from now on
(a clip, in real time). The camera rides with a node (`--camera car-1`, from its head
position in the rig), or looks over the map (`--camera free`).

    carlaverse render lab.mcap --camera car-1 --at 12.5 --out car1.png
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
from pathlib import Path
from typing import Any

from carlaverse.cli.common import (
    add_fabric_args,
    attend,
    fabric_from_args,
    fail,
    say,
    stop_on_signals,
)

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
        "--at",
        type=float,
        metavar="T",
        help="session time [s] of a recording (default: the first pose)",
    )
    parser.add_argument("--out", type=Path, required=True, help="F.png (a still) or F.mp4 (a clip)")
    parser.add_argument("--duration", type=float, default=5.0, help="clip length [s] (MP4)")
    parser.add_argument("--fps", type=float, default=30.0, help="clip frame rate (MP4)")
    parser.add_argument("--rig", default=DEFAULT_RIG, help="render config with the camera rig")
    parser.add_argument("--width", type=int, help="override the rig's resolution (simple rigs)")
    parser.add_argument("--height", type=int, help="override the rig's resolution (simple rigs)")
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
    from carlaverse.fabric.session import FabricError, FabricUnreachable
    from carlaverse.recording.sink import RecordingError
    from carlaverse.render.live import WorldMissing
    from carlaverse.render.renderer import FollowError

    live = not is_recording(args.source)
    stop = stop_on_signals() if live else threading.Event()  # Ctrl-C leaves a session cleanly
    render = _render_live if live else _render_recording
    try:
        frames = render(args, stop)
    except (FabricUnreachable, WorldMissing) as exc:  # no router, authority or world in time
        waited = f" (waited --join-timeout {args.join_timeout:g} s)"
        return fail("render", f"{exc}{waited}", stop.exit_code() if stop.is_set() else 5)
    except FabricError as exc:
        return fail("render", str(exc), 3)
    except (ConfigError, RecordingError, RenderError, FollowError, ValueError) as exc:
        return fail("render", str(exc), 1)
    print(f"render: {frames} frame(s) -> {args.out}")
    return 0


def _usage_problem(args: argparse.Namespace) -> str:
    """What is wrong with the command line, in one line ('' when nothing)."""
    if args.out.suffix.lower() not in (".png", ".mp4"):
        return f"--out {args.out}: give a .png (still) or .mp4 (clip) file"
    if args.duration <= 0 or args.fps <= 0:
        return "--duration and --fps must be > 0"
    if is_recording(args.source):
        if not Path(args.source).is_file():
            return f"{args.source}: no such recording"
        if args.connect or args.listen or args.roster:
            return "--connect, --listen and --roster are for a live session, not a recording"
        return ""
    if args.at is not None:
        return f"--at is for recordings; a live session ({args.source!r}) renders as it is now"
    if args.join_timeout <= 0:
        return f"--join-timeout {args.join_timeout}: give seconds > 0"
    return _fabric_problem(args)


def _fabric_problem(args: argparse.Namespace) -> str:
    from carlaverse.config import ConfigError
    from carlaverse.fabric.session import FabricError, build_config
    from carlaverse.keys import KeySpaceError, check_token

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


def _render_recording(args: argparse.Namespace, stop: threading.Event) -> int:
    from carlaverse.recording.reading import recorded_map
    from carlaverse.render.recording import RecordedWorld, first_pose_time
    from carlaverse.render.renderer import Renderer

    world = RecordedWorld(args.source)
    start = args.at if args.at is not None else first_pose_time(args.source)
    with Renderer(_config(args), recorded_map(args.source)) as renderer:
        frames = _capture(args, renderer, lambda k: world.frame(start + k / args.fps), stop)
    if world.bad_samples:  # a damaged or foreign sample is skipped, not drawn: say how many
        say("render")(f"{world.bad_samples} recorded samples could not be read and were skipped")
    return frames


def _render_live(args: argparse.Namespace, stop: threading.Event) -> int:
    from carlaverse.fabric.node_client import NodeSettings
    from carlaverse.keys import Keys

    deadline = time.monotonic() + args.join_timeout
    fabric = fabric_from_args(args)
    session, notice = attend("render", fabric, Keys(args.source), stop, deadline)
    try:
        node = NodeSettings(node_id=args.node_id, session=args.source)
        return _draw_live(args, session, node, deadline, stop)
    finally:
        notice.close()
        session.close()


def _draw_live(args: argparse.Namespace, session: Any, node: Any, deadline: float,
               stop: threading.Event) -> int:  # fmt: skip
    from carlaverse.render.live import LiveWorld
    from carlaverse.render.renderer import Renderer

    world = LiveWorld(session, node, own=None).start()
    try:
        road_map = world.wait_for_map(deadline, stop)
        follow = None if args.camera == FREE else args.camera
        world.wait_for_actors(deadline, stop, actor_id=follow)
        pace = RealTime(world.frame, args.fps)
        with Renderer(_config(args), road_map) as renderer:
            frames = _capture(args, renderer, pace, stop)
        if pace.repeated:
            slow = "drawing is slower than --fps; the clip keeps the session's pace"
            say("render")(f"{pace.repeated} of {frames} frames repeat the one before: {slow}")
        return frames
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

    def __call__(self, k: int) -> Any:
        late_s = time.monotonic() - (self.start + k * self.period_s)
        if k > 0 and late_s > self.period_s:
            self.repeated += 1
            return None
        time.sleep(max(0.0, -late_s))
        return self.frame()


def _capture(args: argparse.Namespace, renderer: Any, frame_at: Callable[[int], Any],
             stop: threading.Event) -> int:  # fmt: skip
    """Draw frame 0 into a PNG, or frames 0.. of `--duration` into an MP4; returns how many
    frames were written. `frame_at(k)` None repeats the previous image."""
    from carlaverse.render.video import ClipWriter, save_png

    follow = None if args.camera == FREE else args.camera
    if args.out.suffix.lower() == ".png":
        renderer.draw(frame_at(0), follow=follow)
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
                renderer.draw(frame, follow=follow)
            clip.add(renderer.images()[0])
    finally:
        clip.close()
    return clip.frames
