"""`carlaverse motion-server`: the motion-platform server (paper, "Motion Platform Server").

    carlaverse motion-server --verbose                          # log every frame
    carlaverse motion-server --backend csv -o path=motion.csv   # timestamped rows
    carlaverse motion-server --backend dbox                     # a lab's SDK plugin

`--verbose` (or -v) shows each frame; a lab's vendor SDK plugs in as a backend (see
`carlaverse.hal.motion_server.platform`) without any change on the client side.
"""

from __future__ import annotations

import argparse

from carlaverse.cli import hal_common
from carlaverse.cli.common import fail
from carlaverse.config import ConfigError
from carlaverse.hal.errors import HalError
from carlaverse.hal.motion_packet import DEFAULT_MOTION_PORT
from carlaverse.hal.motion_server import MotionServer, registry


def add_arguments(parser: argparse.ArgumentParser) -> None:
    hal_common.add_server_args(parser, DEFAULT_MOTION_PORT, "log (default), csv")


def run(args: argparse.Namespace) -> int:
    if args.list_backends:
        return hal_common.list_backends(registry())
    backend = args.backend or "log"
    try:
        options = hal_common.parse_options(args.option)
        platform = hal_common.open_backend(registry(), backend, options)
    except (ConfigError, HalError) as exc:
        return fail("motion-server", str(exc))
    try:
        server = MotionServer(platform, args.bind, args.port, watchdog_s=args.watchdog_ms / 1000)
    except OSError as exc:
        platform.close()
        return fail("motion-server", f"cannot listen on {args.bind}:{args.port}: {exc}")
    return hal_common.serve("motion-server", server, backend, args, lambda: summary(server))


def summary(server: MotionServer) -> str:
    s = server.stats
    return (
        f"{s.received} packets, {s.frames} frames, {s.short} short, {s.long} long, "
        f"{s.unknown_command} unknown commands, {s.invalid_value} invalid values, "
        f"{s.neutral_events} watchdog neutrals"
    )
