"""`carlaverse ffb-server`: the force-feedback server (paper, "Force Feedback Server").

carlaverse ffb-server --device /dev/input/event7           # evdev wheel on Linux
carlaverse ffb-server --backend log -v                     # dry run: log what would apply
carlaverse ffb-server --device G29 --watchdog-ms 150 -o gain_percent=70
"""

from __future__ import annotations

import argparse

from carlaverse.cli import hal_common
from carlaverse.cli.common import fail
from carlaverse.config import ConfigError
from carlaverse.hal.errors import HalError
from carlaverse.hal.ffb_packet import DEFAULT_FFB_PORT
from carlaverse.hal.ffb_server import FfbServer, registry


def add_arguments(parser: argparse.ArgumentParser) -> None:
    hal_common.add_server_args(parser, DEFAULT_FFB_PORT, "evdev (Linux), log")
    parser.add_argument(
        "--device",
        help="evdev device: /dev/input/eventN or part of its name; implies --backend evdev",
    )


def run(args: argparse.Namespace) -> int:
    if args.list_backends:
        return hal_common.list_backends(registry())
    backend = args.backend or ("evdev" if args.device else "log")
    try:
        options = hal_common.parse_options(args.option)
        if args.device:
            options["device"] = args.device
        actuator = hal_common.open_backend(registry(), backend, options)
    except (ConfigError, HalError) as exc:
        return fail("ffb-server", str(exc))
    try:
        server = FfbServer(actuator, args.bind, args.port, watchdog_s=args.watchdog_ms / 1000)
    except OSError as exc:
        actuator.close()
        return fail("ffb-server", f"cannot listen on {args.bind}:{args.port}: {exc}")
    return hal_common.serve("ffb-server", server, backend, args, lambda: summary(server))


def summary(server: FfbServer) -> str:
    s = server.stats
    return (
        f"{s.received} packets, {s.applied} applied, {s.wrong_size} wrong size, "
        f"{s.out_of_range} out of range, {s.watchdog_trips} watchdog stops, "
        f"{s.device_errors} device errors"
    )
