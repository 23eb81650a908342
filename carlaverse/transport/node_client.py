"""NodeClient: everything a node does on the fabric, behind one object (docs/architecture.md §7).

    session = open_session(settings.fabric)
    client = NodeClient(session, settings.node, MonotonicClock())
    client.start(pose_source=lambda t: my_pose_at(t))
    ...
    now = client.update()            # on the node's own loop: apply what arrived
    for view in client.world.ego_views(now): draw(view)
    client.close()

Threads: Zenoh's callbacks (`transport.inbound`) check and hand over to the world view's intake,
never wait or raise;
a publisher thread sends the ego pose at the configured rate; a control thread joins (and
re-joins after an authority restart or a partition), keeps the session clock in sync, and
nothing else. The node's own control loop never calls into Zenoh.
"""

from __future__ import annotations

import logging
import socket
import threading
import uuid
from collections import deque
from collections.abc import Callable

import msgspec
import zenoh

from carlaverse import __version__
from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, Keys, check_token
from carlaverse.support.tally import Tally
from carlaverse.transport.clock import Clock, SessionClock
from carlaverse.transport.inbound import Inbound
from carlaverse.transport.interest import InterestArea, TiledPublisher
from carlaverse.transport.settings import NodeSettings
from carlaverse.world.world_view import WorldView
from carlaverse.zenoh_replies import ask

log = logging.getLogger(__name__)

PoseSource = Callable[[float], m.Pose | None]

LEAVE_EVENT_WAIT_S = 1.5  # [s] longest a leaving node waits to see its own `left` event
CLOCK_QUERY_TIMEOUT_S = 0.5  # [s] one clock exchange at most (its error bound is RTT / 2)


class JoinRefused(RuntimeError):
    """The authority refused this node (a duplicate id, a schema mismatch)."""


class FabricCounters(msgspec.Struct, frozen=True):
    """What a node's fabric layer counted: for its exit summary and `stats`."""

    dropped: dict[str, int]  # undecodable payloads, by channel (and failed queries' replies)
    rejected: dict[str, int]  # well-formed but refused, by `<channel>/<why>`
    handler_errors: dict[str, int]  # unexpected exceptions in callbacks, by handler
    impulses_accepted: int  # impulses handed to the node after de-duplication
    before_join: dict[str, int] = {}  # world messages ignored while no authority was joined


class NodeClient:
    def __init__(
        self,
        session: zenoh.Session,
        settings: NodeSettings,
        clock: Clock,
        config_yaml: str = "",
        *,
        own_actor: str = "",
        skeletons: bool = False,
        audio_scenes: Callable[[m.AudioScene], None] | None = None,
    ) -> None:
        """`own_actor`: the actor this node's world view leaves out, its own (by default its
        own id; a render process that joins as `<node id>.view` names its node, whose actor
        it reads from shared memory: those poses are never decoded). `skeletons`: hear every
        walker's joints too (`ego/*/skeleton`), for a node that draws bodies. `audio_scenes`:
        hear this node's audio scenes (`audio/<id>`) and hand each the authority sent to it,
        on Zenoh's thread (it must not wait), for a node that plays them."""
        check_token(settings.node_id)
        if settings.site:  # the authority refuses any other (authority/join_check.py)
            check_token(settings.site, "site name")
        if settings.node_id == AUTHORITY_ID:
            raise JoinRefused(f"node id {AUTHORITY_ID!r} is reserved for the authority")
        self.session = session
        self.settings = settings
        self.keys = Keys(settings.session)
        self.clock = SessionClock(clock)
        self.instance = uuid.uuid4().hex
        self.config_yaml = config_yaml
        self.world = WorldView(own_actor or settings.node_id, settings.interpolation)
        self.inbound = Inbound(
            settings.node_id, self.world.intake, self.clock, self._authority_lost,
            self._authority_seen, direct_poses=settings.direct_pose_callbacks,
        )  # fmt: skip
        self._skeletons = skeletons
        self._audio_scenes = audio_scenes
        self._skeleton_pub: zenoh.Publisher | None = None
        self._skeleton_seq = 0
        self.impulses: deque[m.Impulse] = self.inbound.impulses
        self.overrides: deque[m.Override] = self.inbound.overrides
        self.dropped: Tally = self.inbound.dropped
        self.joined = threading.Event()  # accepted by the current authority
        self.admitted = threading.Event()  # accepted at least once: poses may flow
        self.refused: str | None = None
        # What the join waits for when the authority is there but its answer is not: a query
        # that times out (a loaded authority or link) is asked again, never a refusal.
        self.unanswered = ""
        self._clock_unanswered = False  # said once per run of unanswered clock queries
        self._settled = threading.Event()  # the first join was answered, yes or no
        self.join_reply: m.JoinReply | None = None
        self.snapshot: m.Snapshot | None = None
        self.joins = 0
        self.poses_sent = 0
        self._seq = 0
        self._state_seq = 0
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._sync_now = threading.Event()  # an authority appeared: sync (and check) at once
        self._token: zenoh.LivelinessToken | None = None
        self._entities: list[object] = []
        self._threads: list[threading.Thread] = []
        self.interest: InterestArea | None = None
        if settings.interest_radius_m > 0 and settings.actor_kind:
            on_pose, on_npc = self.inbound.spatial_handlers()
            self.interest = InterestArea(
                session, self.keys, settings.interest_radius_m, on_pose, on_npc
            )
            self.world.intake.interest(frozenset())  # nothing in earshot before our first pose
        self._interest_due = threading.Event()
        self._pose_pub = TiledPublisher(
            session,
            self.keys,
            settings.node_id,
            # Our own `ego/*/pose` subscriber would otherwise get each put delivered in the
            # publishing thread, running a Python callback before the sample leaves.
            allowed_destination=zenoh.Locality.REMOTE,
        )
        self._state_pub = session.declare_publisher(
            self.keys.state(settings.node_id),
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )

    @property
    def node_id(self) -> str:
        return self.settings.node_id

    def now(self) -> float:
        """Session time [s]."""
        return self.clock.now()

    # ------------------------------------------------------------ lifecycle

    def counters(self) -> FabricCounters:
        inbound = self.inbound
        return FabricCounters(
            dropped=inbound.dropped.snapshot(),
            rejected=inbound.rejected.snapshot(),
            handler_errors=inbound.guard.errors.snapshot(),
            impulses_accepted=inbound.accepted["impulse"],
            before_join=inbound.before_join.snapshot(),
        )

    def start(self, pose_source: PoseSource | None = None) -> NodeClient:
        spatial = self.interest is None
        self._entities += self.inbound.subscribe(
            self.session, self.keys, spatial=spatial, digest=self.settings.pose_digest,
            skeletons=self._skeletons, audio=self._audio_scenes,
        )  # fmt: skip
        self._spawn(self._control_loop, "control")
        if self.interest is not None:
            self._spawn(self._interest_loop, "interest")
        if pose_source is not None:
            self._spawn(lambda: self._publish_loop(pose_source), "pose")
        return self

    def wait_joined(self, timeout: float) -> bool:
        """Block until accepted; raise JoinRefused if the authority said no."""
        if not self._settled.wait(timeout):
            return False
        if self.refused is not None:
            raise JoinRefused(self.refused)
        return True

    def close(self) -> None:
        """Leave the session on purpose (despawn reason `left`), then drop everything."""
        self._stop.set()
        self._wake.set()
        self._interest_due.set()
        for thread in self._threads:
            thread.join(timeout=3)
        if self.interest is not None:
            self.interest.close()
        self._pose_pub.undeclare()
        if self._skeleton_pub is not None:
            self._skeleton_pub.undeclare()
            self._skeleton_pub = None
        if self._token is not None:
            self._leave()
            self._token.undeclare()  # whoever missed the `left` event despawns us now
            self._token = None
        for entity in self._entities:
            entity.undeclare()  # type: ignore[attr-defined]
        self._entities.clear()
        self.inbound.close()

    def _spawn(self, target: Callable[[], None], name: str) -> None:
        thread = threading.Thread(target=target, name=f"{self.node_id}-{name}", daemon=True)
        thread.start()
        self._threads.append(thread)

    # ------------------------------------------------------------ publishing

    def publish_pose(self, pose: m.Pose) -> bool:
        """Send one pose sample now (sequence number assigned here); never blocks."""
        if not self.admitted.is_set():
            return False
        self._seq += 1
        self._pose_pub.put(m.encode_pose(pose, self._seq), pose.x, pose.y)
        self.poses_sent += 1
        if self.interest is not None and self.interest.moved_to(pose.x, pose.y):
            self._interest_due.set()  # re-subscribing waits on Zenoh: not in this thread
        return True

    def _interest_loop(self) -> None:
        """Move the interest area's subscriptions after the node, off the pose thread."""
        area = self.interest
        assert area is not None
        while True:
            self._interest_due.wait()
            if self._stop.is_set():
                return
            self._interest_due.clear()
            area.refresh()
            self.world.intake.interest(area.tiles)

    def publish_skeleton(self, skeleton: m.Skeleton) -> bool:
        """Send a body's joints (`ego/<id>/skeleton`) with the next sequence number, its `t`
        (the source's own monotonic time [s]) moved onto session time. False, and nothing
        sent, while the session clock has no offset to move it by."""
        if not self.clock.synced:
            return False
        if self._skeleton_pub is None:  # declared by the nodes that have a body, once
            self._skeleton_pub = self.session.declare_publisher(
                self.keys.ego(self.node_id, "skeleton"),
                congestion_control=zenoh.CongestionControl.DROP,
            )
        self._skeleton_seq += 1
        stamped = msgspec.structs.replace(
            skeleton, seq=self._skeleton_seq, t=skeleton.t + self.clock.offset
        )
        self._skeleton_pub.put(m.SKELETON.encode(stamped))
        return True

    def publish_state(self, state: m.EgoState) -> None:
        self._state_seq += 1
        payload = m.EGO_STATE.encode(msgspec.structs.replace(state, seq=self._state_seq))
        self._state_pub.put(payload)

    def _publish_loop(self, source: PoseSource) -> None:
        period = 1.0 / self.settings.pose_rate_hz
        local = self.clock.local
        next_t = local.now()
        while not self._stop.is_set():
            try:
                pose = source(self.now())
                if pose is not None:
                    self.publish_pose(pose)
            except Exception:  # a broken source must not kill presence; say so loudly
                self.dropped.add("pose_source")
                log.exception("pose source of %s failed", self.node_id)
            next_t += period
            delay = next_t - local.now()
            if delay < -period:  # fell behind (suspended?): do not burst to catch up
                next_t, delay = local.now(), 0.0
            self._stop.wait(max(0.0, delay))

    # ------------------------------------------------------------ world updates

    def update(self) -> float:
        """Apply everything received; return the session time it was applied at."""
        now = self.clock.now()
        self.world.update(now)
        return now

    # ------------------------------------------------------------ control thread

    def _control_loop(self) -> None:
        next_sync = 0.0
        local = self.clock.local
        while not self._stop.is_set():
            if not self.joined.is_set():
                self._try_join()
            if self._sync_now.is_set():
                self._sync_now.clear()
                self.clock.reset()  # a new authority may keep another timeline
                next_sync = 0.0
            if local.now() >= next_sync:
                burst = 8 if not self.clock.synced else 3
                for _ in range(burst):
                    # A silent authority makes each exchange wait out its timeout: a whole
                    # burst would outlive close()'s wait for this thread.
                    if self._stop.is_set():
                        return
                    self._sync_clock()
                next_sync = local.now() + self.settings.clock_sync_period_s
            if self.refused is not None:
                return
            joined = self.joined.is_set()
            wait = next_sync - local.now() if joined else self.settings.join_retry_s
            self._wake.wait(max(0.01, wait))
            self._wake.clear()

    def _authority_lost(self) -> None:
        """The authority forgot us (restart, partition, despawn): join again."""
        self.joined.clear()
        self._wake.set()

    def _authority_seen(self) -> None:
        """An authority token appeared: ask its clock now; `known` says whether to re-join."""
        self._sync_now.set()
        self._wake.set()

    def _leave(self) -> None:
        """Tell the authority we leave, and wait briefly for its `left` event to go out.

        Design: a query rather than a notice on a key, so that only the process that joined
        (it alone knows its `instance`) can make its id leave, and the node knows when the
        authority has heard it. The token is dropped after the `left` event was seen, so peers
        learn the reason before the liveliness DELETE (which alone would read as a loss).
        Without an authority, the token's DELETE despawns us as before.
        """
        if not self.joined.is_set():
            return
        request = m.LeaveRequest(self.node_id, self.instance)
        raw = self._query(self.keys.authority("leave"), m.LEAVE_REQUEST.encode(request), 1.0)
        if raw is not None:
            # The event goes out with the authority's next tick (~20 ms); a loaded host can
            # starve that thread for hundreds of ms, and leaving early turns `left` into a loss.
            self.inbound.left.wait(LEAVE_EVENT_WAIT_S)

    def query(
        self, name: str, payload: bytes = b"", timeout_s: float | None = None
    ) -> bytes | None:
        """The authority's answer to its query `name` ("scenario", "map", ...), else None.

        It blocks up to `timeout_s` (default: the join timeout): call it off a control loop.
        """
        timeout = self.settings.join_timeout_s if timeout_s is None else timeout_s
        return self._query(self.keys.authority(name), payload, timeout)

    def _query(self, key: str, payload: bytes, timeout: float) -> bytes | None:
        return ask(self.session, key, payload, timeout)[0]

    def _try_join(self) -> None:
        s = self.settings
        request = m.JoinRequest(
            schema=m.SCHEMA_VERSION, node_id=s.node_id, instance=self.instance, kind=s.kind,
            actor_kind=s.actor_kind, extent=s.extent, mass_kg=s.mass_kg, site=s.site,
            hostname=socket.gethostname(), version=__version__, pose_rate_hz=s.pose_rate_hz,
            config_yaml=self.config_yaml,
        )  # fmt: skip
        payload = m.JOIN_REQUEST.encode(request)
        raw, error = ask(self.session, self.keys.authority("join"), payload, s.join_timeout_s)
        if raw is None:
            if error:  # the authority cannot read our request; asking again will not help
                self._refuse(error)
            else:
                self.unanswered = (
                    f"waiting for the authority of session {s.session!r} to answer the join: "
                    f"no answer within {s.join_timeout_s:g} s (asking again)"
                )
            return
        self.unanswered = ""
        try:
            reply = m.JOIN_REPLY.decode(raw)
        except m.MessageError as exc:
            self.dropped.add("join")
            log.warning("unreadable join reply: %s", exc)
            return
        if not reply.accepted:
            self._refuse(reply.reason)
            return
        self.join_reply = reply
        self.inbound.authority_id = reply.authority_instance
        if reply.pose_digest_s <= 0:
            self.inbound.without_digest(self.session, self.keys)
        self.joins += 1
        if self._token is None:
            self._token = self.session.liveliness().declare_token(self.keys.node(self.node_id))
        self.admitted.set()
        self.joined.set()
        self._settled.set()
        self._fetch_snapshot()
        log.info("joined session %s as %s (join #%d)", s.session, s.node_id, self.joins)

    def _refuse(self, reason: str) -> None:
        self.refused = reason
        log.error("join refused: %s", reason)
        self._settled.set()

    def _fetch_snapshot(self) -> None:
        """Seed the world with everything present now, so a late joiner misses nothing."""
        raw = self._query(self.keys.authority("snapshot"), b"", self.settings.join_timeout_s)
        if raw is None:
            return
        try:
            snapshot = m.SNAPSHOT.decode(raw)
        except m.MessageError as exc:
            self.dropped.add("snapshot")
            log.warning("unreadable snapshot: %s", exc)
            return
        self.snapshot = snapshot
        self.world.intake.snapshot(snapshot, self.now())

    def _sync_clock(self) -> None:
        local = self.clock.local
        payload = m.CLOCK_REQUEST.encode(m.ClockRequest(self.node_id))
        t0 = local.now()
        raw = self._query(self.keys.authority("clock"), payload, CLOCK_QUERY_TIMEOUT_S)
        t1 = local.now()
        if raw is None:
            self._say_clock_unanswered()
            return
        self._clock_unanswered = False
        try:
            reply = m.CLOCK_REPLY.decode(raw)
        except m.MessageError:
            self.dropped.add("clock")
            return
        self.clock.add_exchange(t0, reply.t, t1)
        if not reply.known and self.joined.is_set() and self.refused is None:
            self.joined.clear()  # the authority lost us (restart, partition): join again
            self._wake.set()

    def _say_clock_unanswered(self) -> None:
        """A loaded authority or link leaves a clock query unanswered now and then; that is
        normal, not an alarm: said once, in words, until an answer comes again."""
        if self._clock_unanswered:
            return
        self._clock_unanswered = True
        log.info(
            "the authority of session %r did not answer a clock query within %g s; asking "
            "again, session time runs on its last estimate meanwhile",
            self.settings.session, CLOCK_QUERY_TIMEOUT_S,
        )  # fmt: skip
