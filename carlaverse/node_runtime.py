"""Running a node kind: config, session, client, loop, summary — shared by every node kind.

A node kind (registered under the entry-point group `carlaverse.nodes`) is a class with

    name: str                       # "scripted", "drive", ...
    config_type: type[StrictStruct] # has `node: NodeSettings` and `fabric: FabricSettings`
    def __init__(self, config) -> None
    def pose_source(self) -> PoseSource | None     # called at the pose rate, fabric thread
    def step(self, client: NodeClient, now: float) -> None   # the node's own loop, ~50 Hz
    def close(self) -> None
    def report(self) -> dict[str, object]          # extra fields for the exit summary

`run_node` owns the rest: opening the session, joining, the loop, a clean exit. Until the
authority admits the node it says (through `on_wait`) what it waits for, and after, what it
lost mid-session (the authority, the router) and when that is back: the node's own loop runs
on meanwhile. `duration_s` bounds the whole run, waiting included.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any, Protocol

import msgspec

from carlaverse.config import StrictStruct, to_yaml
from carlaverse.keys import Keys
from carlaverse.messages import AudioScene, Notice, Pose
from carlaverse.redact import redact_yaml
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.transport.session import FabricSettings, open_session
from carlaverse.transport.waiting import POLL_S, SessionWait, WaitNotice
from carlaverse.world.stream_summary import StreamSummary

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "carlaverse.nodes"


class NodeKind(Protocol):
    name: str
    config_type: type[StrictStruct]

    def pose_source(self) -> PoseSource | None: ...
    def step(self, client: NodeClient, now: float) -> None: ...
    def close(self) -> None: ...
    def report(self) -> dict[str, Any]: ...


# A part of the node that shares its session: (session, keys) -> what closes it again.
SessionUser = Callable[[Any, Keys], Callable[[], None]]


class AudioFeed(Protocol):
    """A node's audio process (`audio.process.AudioProcess`): the scenes the node's client
    accepts and the poses it publishes go there, handed over without waiting."""

    def scene(self, scene: AudioScene) -> None: ...
    def pose(self, pose: Pose) -> None: ...


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
    # The fabric layer's counters (NodeClient.counters()): undecodable payloads by channel,
    # well-formed but refused messages by `<channel>/<why>` (duplicate impulses among them),
    # exceptions caught in callbacks, impulses handed to the node after de-duplication.
    dropped: dict[str, int] = {}
    rejected: dict[str, int] = {}
    handler_errors: dict[str, int] = {}
    impulses_accepted: int = 0
    peers: dict[str, StreamSummary] = {}
    clock_uncertainty_ms: float | None = None  # [ms] None until the first clock exchange
    extra: dict[str, Any] = {}
    # Never admitted: what it was still waiting for when stopped or out of time.
    waiting_for: str = ""
    before_join: dict[str, int] = {}  # world messages that came while no authority was joined


class UnknownNodeKind(LookupError):
    pass


class JoinTimeout(TimeoutError):
    """The authority did not admit the node within the join timeout."""


def node_kinds() -> dict[str, Any]:
    """Registered node kinds, name -> entry point (loaded lazily)."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def load_node_kind(name: str) -> type[NodeKind]:
    kinds = node_kinds()
    if name not in kinds:
        import difflib

        close = difflib.get_close_matches(name, kinds, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise UnknownNodeKind(f"unknown node kind {name!r}{hint} (known: {', '.join(kinds)})")
    return kinds[name].load()


class RunLimits(msgspec.Struct, frozen=True):
    """When a node run ends, on the monotonic clock [s]."""

    started: float
    end: float | None  # --duration: the whole run, waiting included
    join_by: float | None  # --join-timeout: admitted by then or JoinTimeout

    @property
    def wait_ends(self) -> float | None:
        """When waiting to be admitted ends, opening the session (a client's router) included."""
        ends = [t for t in (self.end, self.join_by) if t is not None]
        return min(ends) if ends else None

    @classmethod
    def from_now(cls, duration_s: float | None, join_timeout_s: float | None) -> RunLimits:
        now = time.monotonic()
        return cls(
            now,
            None if duration_s is None else now + duration_s,
            None if join_timeout_s is None else now + join_timeout_s,
        )


def run_node(
    node: NodeKind,
    node_settings: NodeSettings,
    fabric: FabricSettings,
    config: StrictStruct,
    duration_s: float | None,
    stop: threading.Event,
    join_timeout_s: float | None = None,
    loop_hz: float = 50.0,
    on_wait: Callable[[str], None] | None = None,
    on_notice: Callable[[Notice], None] | None = None,
    audio: AudioFeed | None = None,
    on_session: SessionUser | None = None,
) -> NodeSummary:
    """Join, run the node's loop until `duration_s` or `stop`, leave cleanly, summarise.
    `audio`: a process that plays what the node hears (its client subscribes to the node's
    audio scenes only then: the authority builds scenes only for a node that listens).
    `on_session(session, keys)`: a part of the node that uses its session too (the HMI's
    questionnaires); called once the client runs, it returns what closes it again, called
    before the client closes.

    Raises FabricUnreachable (client mode: no router before the end), JoinRefused and
    JoinTimeout; a node stopped or out of time before it was admitted returns `joined=False`
    with `waiting_for` saying what was missing.
    """
    limits = RunLimits.from_now(duration_s, join_timeout_s)
    say = on_wait or log.warning
    close_node = _once(node.close)
    try:
        session = open_session(fabric, stop, limits.wait_ends, say)
        try:
            client = NodeClient(
                session, node_settings, MonotonicClock(), config_yaml=redact_yaml(to_yaml(config)),
                audio_scenes=audio.scene if audio is not None else None,
            )  # fmt: skip
            notice = WaitNotice(SessionWait(session, fabric, client.keys), say)
            try:
                client.start(pose_source=_heard_by(node.pose_source(), audio))
                stop_user = on_session(session, client.keys) if on_session else None
                try:
                    missing = _wait_admitted(client, notice, stop, limits)
                    if not missing:
                        notice.watch()  # an authority that goes mid-session is said, and back
                        _loop(node, client, limits, stop, 1.0 / loop_hz, on_notice)
                finally:
                    if stop_user is not None:
                        stop_user()
                notice.close()  # silent from here: the authority may stop beside us
                close_node()  # first: its report (e.g. the control loop's timing) is final
                client.close()  # then publishing stops, so the counts below are final too
                summary = _summary(node, client, time.monotonic() - limits.started)
                return msgspec.structs.replace(summary, waiting_for=missing)
            finally:
                notice.close()
                client.close()
        finally:
            session.close()
    finally:
        close_node()  # also when never connected: a node may own processes or devices


def _finite_ms(seconds: float) -> float | None:
    """Milliseconds for JSON, which has no NaN or infinity: None when not known."""
    return round(seconds * 1e3, 3) if math.isfinite(seconds) else None


def _once(action: Callable[[], None]) -> Callable[[], None]:
    done = False

    def run_once() -> None:
        nonlocal done
        if not done:
            done = True
            action()

    return run_once


def _heard_by(source: PoseSource | None, audio: AudioFeed | None) -> PoseSource | None:
    """The node's pose source, each pose it gives also handed to the audio process."""
    if source is None or audio is None:
        return source

    def told(t: float) -> Pose | None:
        pose = source(t)
        if pose is not None:
            audio.pose(pose)
        return pose

    return told


def _wait_admitted(
    client: NodeClient, notice: WaitNotice, stop: threading.Event, limits: RunLimits
) -> str:
    """Block until admitted (""), or return what is missing when stopped or out of time."""
    while not client.wait_joined(POLL_S):  # raises JoinRefused
        missing = notice.poll(client.unanswered or None) or (
            f"waiting for the authority of session {client.keys.session!r}"
        )
        now = time.monotonic()
        if stop.is_set() or (limits.end is not None and now >= limits.end):
            return missing
        if limits.join_by is not None and now >= limits.join_by:
            raise JoinTimeout(missing)
    # the join reply may arrive before the authority's token: say so from the join itself
    notice.resolved(f"admitted to session {client.keys.session!r} by its authority")
    return ""


def _loop(
    node: NodeKind,
    client: NodeClient,
    limits: RunLimits,
    stop: threading.Event,
    period: float,
    on_notice: Callable[[Notice], None] | None,
) -> None:
    next_t = time.monotonic()
    while not stop.is_set():
        if limits.end is not None and time.monotonic() >= limits.end:
            break
        now = client.update()
        node.step(client, now)
        _hand_on(client.world.notices, on_notice)
        next_t += period
        stop.wait(max(0.0, next_t - time.monotonic()))


def _hand_on(notices: deque[Notice], on_notice: Callable[[Notice], None] | None) -> None:
    """Scenario messages for this participant go to whoever shows them (HMI, terminal)."""
    while notices:
        notice = notices.popleft()
        if on_notice is not None:
            on_notice(notice)


def _summary(node: NodeKind, client: NodeClient, duration: float) -> NodeSummary:
    now = client.update()
    world = client.world
    counters = client.counters()
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
        dropped=counters.dropped,
        rejected=counters.rejected,
        handler_errors=counters.handler_errors,
        impulses_accepted=counters.impulses_accepted,
        before_join=counters.before_join,
        peers={k: s.summary(now) for k, s in sorted(world.stats.items())},
        clock_uncertainty_ms=_finite_ms(client.clock.uncertainty_s),
        extra=node.report(),
    )
