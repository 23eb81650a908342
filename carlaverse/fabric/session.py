"""Opening Zenoh sessions from typed settings (DESIGN §2).

Nodes are `peer`s by default, the site router is a `router`, and `client` is there for
constrained networks. Defaults are chosen for a simulation fabric rather than Zenoh's own:
multicast scouting off (a lab network should not be sprayed with 224.0.0.224), listen only on
loopback unless told otherwise (Zenoh's default binds every interface), and a transport lease
short enough that a crashed node is noticed well within the despawn timeout.
"""

from __future__ import annotations

import json
from typing import Any, Literal

import msgspec
import zenoh

from carlaverse.config import StrictStruct

Mode = Literal["peer", "client", "router"]


class FabricError(RuntimeError):
    """A Zenoh session could not be configured or opened."""


class FabricSettings(StrictStruct):
    """How a process attaches to the fabric; the `fabric:` section of any config."""

    mode: Mode = "peer"
    listen: list[str] = []
    connect: list[str] = []
    multicast_scouting: bool = False
    # A crashed peer is declared gone after `lease_ms` without traffic; keep it well under the
    # despawn timeout (default 3 s). Keep-alives are sent `keep_alive` times per lease.
    lease_ms: int = msgspec.field(default=2000)
    keep_alive: int = 4
    # Zenoh's low-latency transport: saves ~20-60 µs a hop; must be on for every process of
    # a path, and disables QoS priorities.
    lowlatency: bool = False
    # Raw Zenoh config entries (json5 path -> value) for what has no field here: TLS files,
    # authentication, access control. Applied last.
    zenoh: dict[str, Any] = {}


def default_listen(mode: Mode) -> list[str]:
    """Loopback only: a node reaches other hosts through its site router unless told otherwise."""
    if mode == "client":
        return []
    return ["tcp/127.0.0.1:0"]


def build_config(settings: FabricSettings) -> zenoh.Config:
    """Translate settings into a zenoh.Config; raise FabricError naming the bad entry."""
    entries: dict[str, Any] = {
        "mode": settings.mode,
        "scouting/multicast/enabled": settings.multicast_scouting,
        "listen/endpoints": settings.listen or default_listen(settings.mode),
        "connect/endpoints": settings.connect,
        "transport/link/tx/lease": settings.lease_ms,
        "transport/link/tx/keep_alive": settings.keep_alive,
        # Keep retrying connects forever in every mode: a node outlives a router restart.
        "connect/timeout_ms": {"router": -1, "peer": -1, "client": -1},
        "connect/exit_on_failure": {"router": False, "peer": False, "client": False},
        "connect/retry": {
            "period_init_ms": 250,
            "period_max_ms": 2000,
            "period_increase_factor": 2,
        },
    }
    if settings.lowlatency:
        entries["transport/unicast/lowlatency"] = True
        entries["transport/unicast/qos/enabled"] = False
    entries.update(settings.zenoh)
    config = zenoh.Config()
    for path, value in entries.items():
        try:
            config.insert_json5(path, json.dumps(value))
        except Exception as exc:  # zenoh raises ZError with the parser's message
            raise FabricError(f"invalid zenoh setting {path} = {value!r}: {exc}") from exc
    return config


def open_session(settings: FabricSettings) -> zenoh.Session:
    """Open a Zenoh session; errors name the endpoints involved."""
    config = build_config(settings)
    try:
        return zenoh.open(config)
    except Exception as exc:
        raise FabricError(
            f"cannot open a zenoh {settings.mode} session "
            f"(listen={settings.listen or default_listen(settings.mode)}, "
            f"connect={settings.connect}): {exc}"
        ) from exc
