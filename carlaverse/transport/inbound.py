"""What a node accepts from the fabric: decode, check the sender, count, hand over.

Every subscriber callback of a `NodeClient` lives here. None of them waits or raises: a payload
that does not decode is counted in `dropped` under its channel; a well-formed message that is
refused (not from the authority, a duplicate impulse, a reserved id) is counted in `rejected`
under `<channel>/<why>`; anything unexpected is counted by the guard and logged at a bounded
rate. Accepted input goes to the world view through its intake (`world.intake`, the one way
in: `Inbound` is the live session's `WorldSource`) or to the node's queues.

Who may speak for the authority. World messages (`world/*`) and impulses must come from the
Zenoh session of the authority this node joined. The authority stamps each of them with a Zenoh
timestamp from its own session (`Session.new_timestamp()`, whose id is the session's zid) and
names that zid in its join reply (`JoinReply.authority_instance`); samples whose timestamp id
differs, or that carry none, are rejected. Limits, honestly: Zenoh does not authenticate
timestamps. In an open session anyone who learns the authority's zid (it is in every join
reply) can stamp a forged put with it; this check stops stray publishers, replays of old
recordings, a second authority and naive injection, not a determined forger. With `--roster`
the router's ACL allows puts on `world/**` and `impulse/**` only from the authority's
credentials, and that is what enforces it.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable

import zenoh

from carlaverse import messages as m
from carlaverse.keys import AUTHORITY_ID, Keys, KeySpaceError, parse, parse_cached
from carlaverse.support.tally import Tally
from carlaverse.transport.clock import SessionClock
from carlaverse.transport.guard import HandlerGuard
from carlaverse.transport.key_routes import KeyRoutes
from carlaverse.world.intake import WorldIntake

log = logging.getLogger(__name__)

SEEN_CONTACTS = 1024  # impulses remembered per node to drop re-deliveries


class Inbound:
    """A node's subscriptions.

    `lost()` is called when the authority forgot this node (it left, or despawned us);
    `appeared()` when an authority token appears: it may be the one we joined (a late
    history sample) or a new one that knows nothing of us, which a clock query tells apart.
    The poses of `intake.own_id` (this node's, or those of the node a render process draws
    from shared memory) stop at the intake, never decoded.
    """

    def __init__(
        self,
        node_id: str,
        intake: WorldIntake,
        clock: SessionClock,
        lost: Callable[[], None],
        appeared: Callable[[], None],
        direct_poses: bool = False,
    ) -> None:
        self.node_id = node_id
        # Pose callbacks on Zenoh's network thread (one thread hand-off fewer, see
        # `pose_handler`) instead of zenoh-python's own callback thread.
        self.direct_poses = direct_poses
        self._intake = intake
        self.clock = clock
        # Poses are stamped on arrival with the local clock (for a node, `time.monotonic`
        # itself, no Python frame), and the world view's update turns the stamps into session
        # time: the callback, on a thread that wakes cold for each pose, stays short.
        self._stamp = clock.local.now
        intake.pose_stamp_to_session = clock.at
        self._lost = lost
        self._appeared = appeared
        self.impulses: deque[m.Impulse] = deque(maxlen=256)
        self.overrides: deque[m.Override] = deque(maxlen=64)
        # undecodable payloads, by channel: the intake's tally, since the world view checks
        # the poses on its owner's thread
        self.dropped = intake.dropped
        self.rejected = Tally()  # well-formed but refused, by `<channel>/<why>`
        # World messages that arrive before the join reply names the authority cannot be
        # checked; the snapshot fetched after joining supersedes them. Not hostile: kept apart.
        self.before_join = Tally()
        self.accepted = Tally()  # impulses handed to the node, and whatever else is worth a count
        self.guard = HandlerGuard(log)
        # The ego keys heard through wildcards, by sender, each declared to Zenoh so its route
        # is kept (`key_routes`); declared from subscribe() on.
        self.routes = KeyRoutes(channels=("pose", "state", "skeleton"))
        self._senders = self.routes.senders
        self.authority_id = ""  # zid of the joined authority's session; "" before a join
        self.left = threading.Event()  # the authority announced our own `left` despawn
        self._contacts: deque[tuple[str, int]] = deque(maxlen=SEEN_CONTACTS)
        self._contact_set: set[tuple[str, int]] = set()
        self._contacts_lock = threading.Lock()
        # The subscriber that brings other egos' poses from the whole world (None with an
        # interest area), and what it is: "poses" (a sample each) or "digest" (`world/@egos`).
        self.pose_feed: zenoh.Subscriber | None = None
        self.pose_feed_kind = ""
        self._audio: Callable[[m.AudioScene], None] = _nobody

    @property
    def intake(self) -> WorldIntake:
        return self._intake

    def feed(self, until_t: float) -> None:
        """Nothing left to hand over: each sample went to the intake as it arrived."""

    def subscribe(
        self,
        session: zenoh.Session,
        keys: Keys,
        spatial: bool = True,
        digest: bool = False,
        skeletons: bool = False,
        audio: Callable[[m.AudioScene], None] | None = None,
    ) -> list[object]:
        """Declare the node's subscriptions. `spatial=False`: poses and NPCs come through
        an interest area (`spatial_handlers`) instead of from the whole world; `digest`: the
        whole world's poses come through the authority's digest, many to a sample, instead of
        one sample each; `skeletons`: every walker's joints too (`ego/*/skeleton`), for a node
        that draws bodies; `audio`: where this node's audio scenes (`audio/<id>`, the
        authority's only) go, called on Zenoh's thread, for a node that plays them."""
        g = self.guard
        self.routes.attach(session, name=f"{self.node_id}-key-routes")
        world = {"lights": self._on_lights, "weather": self._on_weather, "events": self._on_event}
        entities: list[object] = []
        if spatial:  # the whole world: its poses (`pose_feed`) and its NPCs in one batch
            world["npc"] = self._on_npc
            self._feed(session, keys, "digest" if digest else "poses")
        if skeletons:
            skeleton = g.sample("skeleton", self._on_skeleton)
            entities.append(session.declare_subscriber(keys.all_ego("skeleton"), skeleton))
        if audio is not None:
            self._audio = audio
            scenes = g.sample("audio", self._on_audio)
            entities.append(session.declare_subscriber(keys.audio(self.node_id), scenes))
        entities += [
            session.declare_subscriber(keys.all_ego("state"), g.sample("state", self._on_state)),
            session.declare_subscriber(
                keys.override(self.node_id), g.sample("override", self._on_override)
            ),
            session.declare_subscriber(
                keys.impulse(self.node_id), g.sample("impulse", self._on_impulse)
            ),
            session.liveliness().declare_subscriber(
                keys.all_nodes, g.sample("presence", self._on_presence), history=True
            ),
        ]
        for channel, handler in world.items():
            guarded = g.sample(channel, handler)
            entities.append(session.declare_subscriber(keys.world(channel), guarded))
        return entities

    def _feed(self, session: zenoh.Session, keys: Keys, kind: str) -> None:
        if kind == "digest":
            self.pose_feed = session.declare_subscriber(keys.pose_digest, self.digest_handler())
        else:
            self.pose_feed = session.declare_subscriber(
                keys.all_ego("pose"), self.pose_handler(), allowed_origin=zenoh.Locality.REMOTE
            )
        self.pose_feed_kind = kind

    def without_digest(self, session: zenoh.Session, keys: Keys) -> None:
        """The joined authority relays no digest: hear each pose on its own key instead
        (for good: a later authority that does relay one changes nothing but the cost)."""
        if self.pose_feed_kind != "digest" or self.pose_feed is None:
            return
        self.pose_feed.undeclare()
        self._feed(session, keys, "poses")
        log.warning(
            "the authority relays no pose digest (its --digest-ms is 0): hearing every pose "
            "on its own key instead"
        )

    def close(self) -> None:
        if self.pose_feed is not None:
            self.pose_feed.undeclare()
            self.pose_feed = None
        self.routes.close()

    def spatial_handlers(self) -> tuple[zenoh.handlers.Callback, Callable[[zenoh.Sample], None]]:
        """The guarded pose and NPC handlers, for the subscriptions of an interest area."""
        return self.pose_handler(), self.guard.sample("npc", self._on_npc)

    def pose_handler(self) -> zenoh.handlers.Callback:
        """The guarded pose callback, on the thread `direct_poses` chooses.

        Direct, it runs on Zenoh's network thread: it decodes, checks and appends to a deque
        and waits on no lock of ours, but it does take the GIL there, which a busy Python
        thread holds for up to `sys.getswitchinterval()` (5 ms), and zenoh-python then
        builds a Python thread state per sample (more CPU per pose than its callback thread).
        """
        # `_on_pose` guards itself: the guard's wrapper would be a Python frame more per pose.
        return zenoh.handlers.Callback(self._on_pose, indirect=not self.direct_poses)

    def digest_handler(self) -> Callable[[zenoh.Sample], None]:
        """The guarded callback for the authority's pose digest (`world/@egos`), on
        zenoh-python's callback thread: one sample brings dozens of poses."""
        return self.guard.sample("digest", self._on_digest)

    # ------------------------------------------------------------ checks

    def _decode(self, sample: zenoh.Sample, codec: m.Codec, channel: str) -> object | None:
        try:
            return codec.decode(sample.payload.to_bytes())
        except m.MessageError as exc:
            self.dropped.add(channel)
            log.debug("dropped %s on %s: %s", channel, sample.key_expr, exc)
            return None

    def _sender(self, sample: zenoh.Sample, channel: str) -> str | None:
        """The sender of an ego sample (`state`, `skeleton`), or None, counted, if its key is
        not one."""
        key = str(sample.key_expr)
        try:
            return self._senders.get(key) or self.routes.sender(key)
        except KeySpaceError:
            self.dropped.add(channel)
            return None

    def _from_authority(self, sample: zenoh.Sample, channel: str) -> bool:
        """Whether the sample was stamped by the joined authority's session (module docstring)."""
        if not self.authority_id:
            self.before_join.add(channel)
            return False
        stamp = sample.timestamp
        if stamp is not None and self.authority_id and str(stamp.get_id()) == self.authority_id:
            return True
        self.rejected.add(f"{channel}/not_from_authority")
        return False

    def _authority_message(self, sample: zenoh.Sample, codec: m.Codec, channel: str) -> object:
        """Decode a world message or impulse; None if undecodable or not the authority's."""
        message = self._decode(sample, codec, channel)
        if message is None or not self._from_authority(sample, channel):
            return None
        return message

    # ------------------------------------------------------------ egos

    def _on_pose(self, sample: zenoh.Sample) -> None:
        # The hottest path of a node (every pose of every ego it hears), and the delay of each:
        # the sender from the key (a key heard before is in `routes.senders`; a new one is
        # parsed, and declared to Zenoh off this thread) and the bytes, handed over as they came.
        # The world view's update checks and decodes them, once, with every other pose it
        # drains. The arrival is stamped on the local clock (see __init__).
        try:
            rx_t = self._stamp()
            key = str(sample.key_expr)
            node_id = self._senders.get(key) or self.routes.sender(key)
            self._intake.pose(node_id, sample.payload.to_bytes(), rx_t)
        except KeySpaceError:
            self.dropped.add("pose")
        except Exception as exc:  # as `HandlerGuard.sample` does: count, never raise
            self.guard.failed("pose", exc)

    def _on_digest(self, sample: zenoh.Sample) -> None:
        """Poses relayed by the authority. Each row is checked as a pose of its own would be,
        by the world view's update, with every other pose it drains."""
        rx_t = self._stamp()  # local, as a pose's (see __init__)
        digest = self._authority_message(sample, m.POSE_DIGEST, "digest")
        if isinstance(digest, m.PoseDigest):
            self._intake.pose_rows(digest.ids, digest.rows, rx_t)

    def _on_state(self, sample: zenoh.Sample) -> None:
        node_id = self._sender(sample, "state")
        state = self._decode(sample, m.EGO_STATE, "state")
        if node_id is not None and state is not None:
            self._intake.state(node_id, state)  # type: ignore[arg-type]

    def _on_skeleton(self, sample: zenoh.Sample) -> None:
        node_id = self._sender(sample, "skeleton")
        skeleton = self._decode(sample, m.SKELETON, "skeleton")
        if node_id is not None and skeleton is not None:
            self._intake.skeleton(node_id, skeleton)  # type: ignore[arg-type]

    def _on_override(self, sample: zenoh.Sample) -> None:
        override = self._decode(sample, m.OVERRIDE, "override")
        if override is not None:
            self.overrides.append(override)  # type: ignore[arg-type]

    def _on_presence(self, sample: zenoh.Sample) -> None:
        try:  # `node/<id>`: a token each, rarely heard, no route worth keeping
            node_id = parse_cached(str(sample.key_expr)).node_id
        except KeySpaceError:
            self.dropped.add("presence")
            return
        alive = sample.kind == zenoh.SampleKind.PUT
        if node_id == AUTHORITY_ID:
            if alive:
                self._appeared()
            else:
                # The authority we joined is gone: what a next one says before we join it is
                # early (`before_join`), not forged (`not_from_authority`).
                self.authority_id = ""
                self._lost()
        elif node_id != self.node_id:
            if alive:
                self._intake.present(node_id)
            else:
                self._intake.gone(node_id, "liveliness", self.clock.now())

    # ------------------------------------------------------------ the authority's

    def _on_npc(self, sample: zenoh.Sample) -> None:
        rx_t = self.clock.now()
        batch = self._authority_message(sample, m.NPC_BATCH, "npc")
        if batch is None:
            return
        try:
            tile = parse(str(sample.key_expr)).tile  # "" on `world/npc`: the whole world
        except KeySpaceError:
            self.dropped.add("npc")
            return
        self._intake.npc(batch, rx_t, tile)  # type: ignore[arg-type]

    def _on_lights(self, sample: zenoh.Sample) -> None:
        lights = self._authority_message(sample, m.LIGHTS, "lights")
        if lights is not None:
            self._intake.lights(lights)  # type: ignore[arg-type]

    def _on_weather(self, sample: zenoh.Sample) -> None:
        weather = self._authority_message(sample, m.WEATHER, "weather")
        if weather is not None:
            self._intake.weather(weather)  # type: ignore[arg-type]

    def _on_event(self, sample: zenoh.Sample) -> None:
        event = self._authority_message(sample, m.WORLD_EVENT, "events")
        if isinstance(event, m.Despawned):
            self._on_despawned(event)
        elif isinstance(event, m.Spawned):
            if event.node_id == AUTHORITY_ID:
                self.rejected.add("events/reserved_id")  # no actor for the authority, ever
            elif event.node_id != self.node_id:
                self._intake.present(event.node_id)
        elif isinstance(event, m.Notice) and event.to in ("", self.node_id):
            self._intake.notice(event)

    def _on_despawned(self, event: m.Despawned) -> None:
        if event.node_id != self.node_id:
            self._intake.gone(event.node_id, event.reason, self.clock.now())
        elif event.reason == "left":
            self.left.set()  # our own leave, acknowledged: the token may go now
        else:
            log.warning("the authority despawned this node (%s): joining again", event.reason)
            self._lost()

    def _on_audio(self, sample: zenoh.Sample) -> None:
        scene = self._authority_message(sample, m.AUDIO_SCENE, "audio")
        if scene is not None:
            self.accepted.add("audio")
            self._audio(scene)  # type: ignore[arg-type]

    def _on_impulse(self, sample: zenoh.Sample) -> None:
        impulse = self._authority_message(sample, m.IMPULSE, "impulse")
        if impulse is None:
            return
        # What identifies an impulse is who decided it and for which contact; sequence numbers
        # are shared with other messages and restart with the authority.
        if not self._first_time((self.authority_id, impulse.contact_id)):  # type: ignore[attr-defined]
            self.rejected.add("impulse/duplicate")
            return
        self.accepted.add("impulse")
        self.impulses.append(impulse)  # type: ignore[arg-type]

    def _first_time(self, contact: tuple[str, int]) -> bool:
        with self._contacts_lock:
            if contact in self._contact_set:
                return False
            if len(self._contacts) == self._contacts.maxlen:
                self._contact_set.discard(self._contacts[0])
            self._contacts.append(contact)
            self._contact_set.add(contact)
            return True


def _nobody(scene: m.AudioScene) -> None:
    """Where audio scenes go before a node asks for them (it is not subscribed then)."""
