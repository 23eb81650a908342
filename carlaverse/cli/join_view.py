"""`carlaverse join KIND --view`: the node's first-person view, in a render process of its own.

    carlaverse join drive --view                       # a window, riding in the car
    carlaverse join drive --view --offscreen --view-out frames/   # headless, PNGs every 0.5 s
    carlaverse join observer --view --view-camera tum-drive-1     # chase a node (or 'free')

A node kind that exports its own pose in shared memory says where (`own_pose_block()`); the
view then draws the node itself without network delay. Kinds without it get a chase or free
camera. Panda3D is imported only by the render process.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
from collections.abc import Iterator
from typing import Any

import msgspec

from carlaverse.cli.common import Companion
from carlaverse.config import ConfigError, load_config
from carlaverse.transport.node_client import NodeSettings
from carlaverse.transport.session import FabricSettings

DEFAULT_RIG = "rigs/rig-desktop"
# A rider's eye is not a driver's: the default rig per kind of the node's own actor.
KIND_RIGS = {"bicycle": "rigs/rig-bike-desktop", "pedestrian": "rigs/rig-walk-desktop"}


def add_view_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("view (rendered in a process of its own)")
    group.add_argument("--view", action="store_true", help="show the shared world in 3D")
    group.add_argument("--offscreen", action="store_true", help="render without a window")
    group.add_argument("--view-out", metavar="DIR", help="write a PNG of the view to DIR regularly")
    group.add_argument("--view-every", type=float, default=0.5, metavar="S",
                       help="seconds between PNGs written to --view-out")  # fmt: skip
    group.add_argument("--view-camera", metavar="own|free|NODE_ID",
                       help="ride in the node (own, the default when it has a body), look over "
                       "the map (free), or chase NODE_ID")  # fmt: skip
    group.add_argument("--render-config", metavar="RIG",
                       help="render config with the camera rig (path or shipped name); default "
                       f"{KIND_RIGS['bicycle']} for a bike, {KIND_RIGS['pedestrian']} for a "
                       f"walker, else {DEFAULT_RIG}")  # fmt: skip


@contextlib.contextmanager
def node_view(
    args: argparse.Namespace, node: Any, settings: NodeSettings, fabric: FabricSettings
) -> Iterator[Companion]:
    """Run the node's view (when --view) for the duration of the block."""
    view = Companion("view")
    if args.view:
        view.running = _start(args, node, settings, fabric)
    elif args.offscreen or args.view_out or args.view_camera:
        raise ConfigError("--view", "--offscreen, --view-out and --view-camera need --view")
    try:
        yield view
    finally:
        if view.running is not None:
            view.report = view.running.close().report()


def _start(args: argparse.Namespace, node: Any, settings: NodeSettings,
           fabric: FabricSettings) -> Any:  # fmt: skip
    if importlib.util.find_spec("panda3d") is None:
        raise ConfigError("--view", "needs Panda3D: pip install 'carlaverse[render]'")
    if args.view_every <= 0:
        raise ConfigError("--view", f"--view-every {args.view_every}: give seconds > 0")
    from carlaverse.render.process import FREE, OWN, ViewProcess, ViewSpec
    from carlaverse.render.rig import RenderConfig

    own = node.own_pose_block() if hasattr(node, "own_pose_block") else None
    rig = args.render_config or KIND_RIGS.get(own.kind if own is not None else "", DEFAULT_RIG)
    config = load_config(rig, RenderConfig)
    if args.offscreen or args.view_out:
        config = msgspec.structs.replace(config, output="offscreen")
    camera = args.view_camera or (OWN if own is not None else FREE)
    spec = ViewSpec(settings, fabric, config, own, camera, args.view_out, args.view_every)
    return ViewProcess(spec).start()
