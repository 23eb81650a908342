"""`carlaverse render FILE.mcap --camera NODE_ID|free --at T --out F.png|F.mp4`.

Renders a recorded moment (PNG) or a clip (MP4) offscreen, through the same world view a
live node uses. The camera rides with a recorded ego (`--camera car-1`, from its head
position in the rig), or looks over the map (`--camera free`).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from carlaverse.cli.common import fail

DEFAULT_RIG = "rigs/rig-desktop"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, metavar="FILE.mcap", help="a carlaverse recording")
    parser.add_argument("--camera", default="free", help="node id to ride with, or 'free'")
    parser.add_argument("--at", type=float, help="session time [s] (default: the first pose)")
    parser.add_argument("--out", type=Path, required=True, help="F.png (a still) or F.mp4 (a clip)")
    parser.add_argument("--duration", type=float, default=5.0, help="clip length [s] (MP4)")
    parser.add_argument("--fps", type=float, default=30.0, help="clip frame rate (MP4)")
    parser.add_argument("--rig", default=DEFAULT_RIG, help="render config with the camera rig")
    parser.add_argument("--width", type=int, help="override the rig's resolution (simple rigs)")
    parser.add_argument("--height", type=int, help="override the rig's resolution (simple rigs)")


def run(args: argparse.Namespace) -> int:
    suffix = args.out.suffix.lower()
    if suffix not in (".png", ".mp4"):
        return fail("render", f"--out {args.out}: give a .png (still) or .mp4 (clip) file")
    if not args.recording.is_file():
        return fail("render", f"{args.recording}: no such recording")
    if args.duration <= 0 or args.fps <= 0:
        return fail("render", "--duration and --fps must be > 0")
    try:
        from carlaverse.render.graphics import RenderError
    except ImportError as exc:
        return fail("render", f"rendering needs Panda3D ({exc}): pip install 'carlaverse[render]'")
    from carlaverse.config import ConfigError
    from carlaverse.recording.sink import RecordingError
    from carlaverse.render.renderer import FollowError

    try:
        frames = _render(args)
    except (ConfigError, RecordingError, RenderError, FollowError, ValueError) as exc:
        return fail("render", str(exc), 1)
    print(f"render: {frames} frame(s) -> {args.out}")
    return 0


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


def _render(args: argparse.Namespace) -> int:
    from carlaverse.render.recording import RecordedWorld, first_pose_time, recorded_map
    from carlaverse.render.renderer import Renderer
    from carlaverse.render.video import ClipWriter, save_png

    world = RecordedWorld(args.recording)
    follow = None if args.camera == "free" else args.camera
    with Renderer(_config(args), recorded_map(args.recording)) as renderer:
        start = args.at if args.at is not None else first_pose_time(args.recording)
        if args.out.suffix.lower() == ".png":
            renderer.draw(world.frame(start), follow=follow)
            save_png(args.out, renderer.images()[0])
            return 1
        w, h = renderer.layout.outputs[0]
        clip = ClipWriter(args.out, w, h, args.fps)
        try:
            for k in range(max(1, math.floor(args.duration * args.fps))):
                renderer.draw(world.frame(start + k / args.fps), follow=follow)
                clip.add(renderer.images()[0])
        finally:
            clip.close()
        return clip.frames
