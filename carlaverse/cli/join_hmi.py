"""`carlaverse join KIND --hmi PORT`: the node serves its web HMI (dashboard, touchscreen, bike).

    carlaverse join drive --backend sim --hmi 8080          # http://127.0.0.1:8080/dashboard
    carlaverse join drive --hmi 8080 --hmi-bind 0.0.0.0     # a tablet on the lab's network
    carlaverse join bike --hmi 0 --hmi-config my-hmi.yaml   # any free port; layouts of yours

The server runs in a thread of the node process with its own event loop; a node kind takes
part through `hmi_bridge()` (carlaverse.hmi.bridge). Starlette and uvicorn are imported only
when --hmi is given.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Callable, Iterator
from typing import Any

from carlaverse.cli.common import Companion


def add_hmi_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("web HMI (served by the node)")
    group.add_argument(
        "--hmi", type=int, metavar="PORT",
        help="serve the dashboard/touchscreen pages on PORT (0: any free port)",
    )  # fmt: skip
    group.add_argument(
        "--hmi-bind", default="127.0.0.1", metavar="ADDR",
        help="address to serve the HMI on (default 127.0.0.1: this machine only)",
    )  # fmt: skip
    group.add_argument(
        "--hmi-config", metavar="FILE",
        help="HMI layouts and settings (default: the shipped hmi/<kind>.yaml)",
    )  # fmt: skip


@contextlib.contextmanager
def node_hmi(
    args: argparse.Namespace, kind: str, node: Any, say: Callable[[str], None]
) -> Iterator[Companion]:
    """Serve the node's HMI while the block runs, when --hmi was given."""
    hmi = Companion("hmi")
    if args.hmi is None:
        yield hmi
        return
    if not 0 <= args.hmi <= 65535:
        raise ValueError(f"--hmi {args.hmi}: not a TCP port (0..65535; 0 picks a free one)")
    if not hasattr(node, "hmi_bridge"):
        raise ValueError(f"--hmi: node kind {kind!r} has no HMI (drive and bike have one)")
    from carlaverse.hmi.config import default_config_name, load_hmi_config
    from carlaverse.hmi.server import HmiServer

    loaded = load_hmi_config(args.hmi_config or default_config_name(kind))
    bridge = node.hmi_bridge()
    try:
        server = HmiServer(bridge, loaded, args.hmi_bind, args.hmi).start()
    except ValueError:  # HmiError: the address, in one line
        bridge.close()
        raise
    hmi.running = server
    say(f"HMI at {server.url}{loaded.config.hmi.home} (pages: "
        f"{', '.join(server.site.pages())})")  # fmt: skip
    try:
        yield hmi
    finally:
        server.close()
        hmi.report = server.stats()
        bridge.close()
