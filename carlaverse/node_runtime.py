"""Running a node kind: config, session, client, loop, summary — shared by every node kind.

A node kind (registered under the entry-point group `carlaverse.nodes`) is a class with

    name: str                       # "scripted", "drive", ...
    config_type: type[StrictStruct] # has `node: NodeSettings` and `fabric: FabricSettings`
    def __init__(self, config) -> None
    def pose_source(self) -> PoseSource | None     # called at the pose rate, fabric thread
    def step(self, client: NodeClient, now: float) -> None   # the node's own loop, ~50 Hz
    def close(self) -> None
    def report(self) -> dict[str, object]          # extra fields for the exit summary

`run_node` owns the rest: opening the session, joining, the loop, a clean exit.
"""

from __future__ import annotations

import logging
import threading
import time
from importlib.metadata import entry_points
from typing import Any, Protocol

import msgspec

from carlaverse.config import StrictStruct, to_yaml
from carlaverse.fabric.clock import MonotonicClock
from carlaverse.fabric.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.fabric.session import FabricSettings, open_session
from carlaverse.fabric.stats import StreamSummary
from carlaverse.security.redact import redact_yaml

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "carlaverse.nodes"


class NodeKind(Protocol):
    name: str
    config_type: type[StrictStruct]

    def pose_source(self) -> PoseSource | None: ...
    def step(self, client: NodeClient, now: float) -> None: ...
    def close(self) -> None: ...
    def report(self) -> dict[str, Any]: ...


class NodeSummary(msgspec.Struct):
    node_id: str
    kind: str
    session: str
    joined: bool
    refused: str = ""
    joins: int = 0
    duration_s: float = 0.0
    poses_sent: int = 0
    actors_seen: list[str] = []
    actors_now: list[str] = []
    npcs_now: int = 0
    despawns: list[tuple[str, str]] = []  # (node id, reason)
    impulses: int = 0
    dropped: dict[str, int] = {}
    peers: dict[str, StreamSummary] = {}
    clock_uncertainty_ms: float = float("nan")
    extra: dict[str, Any] = {}


class UnknownNodeKind(LookupError):
    pass


def node_kinds() -> dict[str, Any]:
    """Registered node kinds, name -> entry point (loaded lazily)."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def load_node_kind(name: str) -> type:
    kinds = node_kinds()
    if name not in kinds:
        import difflib

        close = difflib.get_close_matches(name, kinds, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise UnknownNodeKind(f"unknown node kind {name!r}{hint} (known: {', '.join(kinds)})")
    return kinds[name].load()


def run_node(
    node: NodeKind,
    node_settings: NodeSettings,
    fabric: FabricSettings,
    config: StrictStruct,
    duration_s: float | None,
    stop: threading.Event,
    join_timeout_s: float = 30.0,
    loop_hz: float = 50.0,
) -> NodeSummary:
    """Join, run the node's loop until `duration_s` or `stop`, leave cleanly, summarise."""
    session = open_session(fabric)
    client = NodeClient(
        session, node_settings, MonotonicClock(), config_yaml=redact_yaml(to_yaml(config))
    )
    started = time.monotonic()
    try:
        try:
            client.start(pose_source=node.pose_source())
            if not client.wait_joined(join_timeout_s):
                log.warning("no authority answered in %.0f s; running unjoined", join_timeout_s)
            _loop(node, client, started, duration_s, stop, 1.0 / loop_hz)
        finally:
            node.close()  # first: its report (e.g. the control loop's timing) is final then
        return _summary(node, client, time.monotonic() - started)
    finally:
        client.close()
        session.close()


def _loop(node: NodeKind, client: NodeClient, started: float, duration_s: float | None,
          stop: threading.Event, period: float) -> None:  # fmt: skip
    next_t = time.monotonic()
    while not stop.is_set():
        if duration_s is not None and time.monotonic() - started >= duration_s:
            break
        now = client.update()
        node.step(client, now)
        next_t += period
        stop.wait(max(0.0, next_t - time.monotonic()))


def _summary(node: NodeKind, client: NodeClient, duration: float) -> NodeSummary:
    now = client.update()
    world = client.world
    return NodeSummary(
        node_id=client.node_id,
        kind=node.name,
        session=client.settings.session,
        joined=client.admitted.is_set(),
        refused=client.refused or "",
        joins=client.joins,
        duration_s=round(duration, 3),
        poses_sent=client.poses_sent,
        actors_seen=sorted(world.seen),
        actors_now=sorted(world.egos),
        npcs_now=len(world.npcs),
        despawns=[(d.actor_id, d.reason) for d in world.despawns],
        impulses=len(client.impulses),
        dropped=dict(client.dropped),
        peers={k: s.summary(now) for k, s in sorted(world.stats.items())},
        clock_uncertainty_ms=round(client.clock.uncertainty_s * 1e3, 3),
        extra=node.report(),
    )
