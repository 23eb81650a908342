"""A node's picture of the world: remote egos and NPCs, lights and weather.

Everything comes in through the view's `intake` (`world.intake`), the one writer, from
whatever source feeds it (`world.source`: a live session, a recording, a synthetic feed):
its methods only append to a deque (atomic under the GIL), so a Zenoh callback never waits,
and the owner of the view applies what came in `update(now)` on its own thread. That keeps
every `RemoteActor` single-threaded and the callbacks cheap. Poses come in as they travel, 64
bytes each. The poses an update drains are checked and decoded once, together
(`messages.decode_pose_rows`), and the decoded `Pose`s are what the senders' streams keep
(`ego_streams`); an actor takes its samples when it is read.

One render time per view: every actor of a view, egos and NPCs, is drawn at the same session
time, so that their relative positions are true (two actors drawn at different times are
misplaced by the difference times their speeds). In `present` mode that time is now; in
`past` mode it is now minus the largest delay any live stream needs, slewed (`DelaySlew`).

No ghosts: an actor is removed when its presence token goes, when the authority announces its
despawn, or when it has been silent for the despawn timeout. A removed id is tombstoned so
that samples still in flight cannot resurrect it; its next appearance (token or spawn event)
lifts the tombstone. Poses count only from present ids, never from the reserved `authority`
id, and only with a time near session time; state per sender is kept for present ids only.

With an interest area (`carlaverse.transport.interest`) the view holds only what is near: NPCs
by tile, egos whose poses arrive; an ego that is out of the area when it falls silent, or
when the area moves away from it, is removed as `far` (not a loss), and its stream
statistics restart when it comes back. `interest` is None for a view of the whole world.
"""

from __future__ import annotations

import logging
import math
from collections import Counter, deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from carlaverse.keys import AUTHORITY_ID, tile_of, tile_token
from carlaverse.messages import (
    EgoInfo,
    EgoState,
    LightsState,
    Notice,
    NpcBatch,
    Pose,
    Skeleton,
    Snapshot,
    Weather,
    decode_pose_rows,
)
from carlaverse.world.ego_streams import Applied, EgoActors, EgoStreams, StreamStatsTable
from carlaverse.world.intake import POSE, ROWS, WHOLE_WORLD, Departure, WorldIntake
from carlaverse.world.interest_npcs import NpcTiles
from carlaverse.world.npc_table import NpcFrame
from carlaverse.world.remote_actor import ActorView, DelaySlew, InterpolationSettings, Phase

log = logging.getLogger(__name__)

TOMBSTONE_S = 30.0  # [s] a tombstone outlives any sample still in flight by far
# [s] how often an update looks for silent actors, expired NPC tiles and old tombstones: their
# timeouts are seconds, and looking at every 50 Hz update cost a node's loop as much CPU per
# pose as the pose's own work (a loop that wakes every 20 ms runs with cold caches).
HOUSEKEEPING_S = 0.1
STATS_LIMIT = 1024  # senders kept at most; beyond, a departed one's place is reused
NOTICE_LIMIT = 32  # scenario messages waiting for the node's loop; older ones are dropped
# Despawns kept for the summary; with interest areas every ego that drives out of a node's
# tiles is one (`far`), so over a long session the oldest go.
DESPAWN_LIMIT = 10_000


@dataclass(frozen=True, slots=True)
class Despawn:
    actor_id: str
    reason: Departure
    t: float


class WorldView:
    def __init__(self, own_id: str, settings: InterpolationSettings) -> None:
        self.own_id = own_id
        self.intake = WorldIntake(own_id)  # the one way in
        # Malformed input by channel: what the sources could not decode, and bad poses
        self.dropped = self.intake.dropped
        self.settings = settings
        # scenario messages for this participant, oldest first; the node's loop takes them
        self.notices: deque[Notice] = deque(maxlen=NOTICE_LIMIT)
        self.streams = EgoStreams(own_id, settings)
        self.egos = EgoActors(self.streams, settings)
        self.npcs = NpcTiles(settings)
        # The tiles this view hears (None: the whole world); set by the node's interest area.
        self.interest: frozenset[str] | None = None
        self._snapshot_egos: list[tuple[EgoInfo, float]] = []  # until the interest is known
        self.ego_states: dict[str, EgoState] = {}
        self.skeletons: dict[str, Skeleton] = {}  # the newest per present walker
        self.lights: LightsState | None = None
        self.weather: Weather | None = None
        self.stats = StreamStatsTable(self.streams)
        self.despawns: deque[Despawn] = deque(maxlen=DESPAWN_LIMIT)
        self.seen: set[str] = set()  # every ego id ever rendered
        self._tombstones: dict[str, float] = {}
        # Poses count only from nodes with a presence token (or announced by the authority):
        # a well-formed pose from a node that never joined is an intruder, not an actor.
        self.present: set[str] = set()
        self.rejected: Counter[str] = Counter()
        self._delay = DelaySlew(settings)
        self._render: tuple[float, float] | None = None  # (now, render time) last computed
        self._housekeeping_due = -math.inf  # [s] session time of the next look for silence
        # inbox tag -> what applies it (poses, most of the items, are gathered instead)
        self._handlers: dict[str, Callable[..., None]] = {
            "skeleton": self._on_skeleton, "npc": self._on_npc, "interest": self._on_interest,
            "gone": self._on_gone, "present": self._on_present, "notice": self._on_notice,
            "state": self._on_state, "snapshot": self._on_snapshot,
            "lights": self._on_lights, "weather": self._on_weather,
        }  # fmt: skip

    @property
    def render_mode(self) -> str:
        return self.settings.render_mode

    @property
    def delay_s(self) -> float:
        """How far behind now this view draws [s] (0 in present mode)."""
        return 0.0 if self.render_mode == "present" else self._delay.delay_s

    # ------------------------------------------------------------ owner thread

    def update(self, now: float) -> None:
        """Apply everything received so far, then expire silent actors.

        Poses are gathered and applied together; anything else applies the poses before it
        first, so that order holds (a pose in flight after its node left is refused)."""
        inbox, handlers = self.intake.inbox, self._handlers
        ids: list[str] = []  # the poses gathered: who sent each, its bytes, when it came
        rows: list[bytes] = []
        rx: list[float] = []
        while inbox:
            item = inbox.popleft()
            tag = item[0]
            # identity, not equality: the tags are interned literals (an equal tag that is not
            # identical still takes the path below, only slower)
            if tag is POSE:  # nearly every item
                ids.append(item[1])
                rows.append(item[2])
                rx.append(item[3])
                continue
            if tag is ROWS:
                ids += item[1]
                rows.append(item[2])
                rx += [item[3]] * len(item[1])
                continue
            if ids:  # the poses before this item apply first: kept in arrival order
                self._apply_rows(ids, rows, rx)
                ids, rows, rx = [], [], []
            handlers[tag](*item[1:])
        if ids:
            self._apply_rows(ids, rows, rx)
        if now >= self._housekeeping_due or now < self._housekeeping_due - HOUSEKEEPING_S:
            self._housekeeping_due = now + HOUSEKEEPING_S  # (a clock stepped back looks now)
            self._expire(now)
            self.npcs.drop_expired(now)
            self._forget_tombstones(now)

    def _apply_rows(self, ids: list[str], rows: list[bytes], rx: list[float]) -> None:
        """Check and decode the gathered poses (once, together), then apply them."""
        to_session = self.intake.pose_stamp_to_session
        if to_session is not None:
            rx = [to_session(t) for t in rx]
        poses = decode_pose_rows(rows[0] if len(rows) == 1 else b"".join(rows))
        if None in poses:  # a bad row: dropped and counted, the rest kept in order
            keep = [k for k, pose in enumerate(poses) if pose is not None]
            self.dropped.add("pose", len(poses) - len(keep))
            ids, rx = [ids[k] for k in keep], [rx[k] for k in keep]
            poses = [poses[k] for k in keep]
        self._apply(self.streams.apply(ids, poses, rx))  # type: ignore[arg-type]

    def _apply(self, applied: Applied) -> None:
        for node_id in applied.restarted:  # a new timeline: the old samples are no path
            self.egos.restart(node_id)
        if applied.absent:
            self.rejected["pose_from_absent_node"] += applied.absent
        if applied.implausible:
            self.rejected["pose_time_implausible"] += applied.implausible
        for node_id in applied.opened:  # senders new to the view
            self.egos.open(node_id)
            self.seen.add(node_id)

    def _expire(self, now: float) -> None:
        """Remove the actors silent for the despawn timeout (every actor is looked at on every
        update, no actor brought up to date unless it expired)."""
        for node_id in self.streams.silent(now, self.settings.despawn_timeout_s):
            reason: Departure = "timeout" if self.hears(self.streams[node_id].newest) else "far"
            self._remove(node_id, reason, now)

    def _on_notice(self, notice: Notice) -> None:
        self.notices.append(notice)

    def _on_lights(self, lights: LightsState) -> None:
        self.lights = lights

    def _on_weather(self, weather: Weather) -> None:
        self.weather = weather

    def _on_npc(self, batch: NpcBatch, rx_t: float, tile: str = WHOLE_WORLD) -> None:
        if not self.npcs.add(batch, rx_t, tile):
            self.rejected["npc_batch"] += 1

    def hears(self, pose: Pose | None) -> bool:
        """Whether a pose lies in this view's interest area (always, for the whole world)."""
        if self.interest is None:
            return True
        return pose is not None and tile_token(*tile_of(pose.x, pose.y)) in self.interest

    def _on_interest(self, tiles: frozenset[str]) -> None:
        self.interest = tiles
        self.npcs.keep_only(tiles)
        for actor_id in list(self.egos):
            stream = self.streams[actor_id]
            if not self.hears(stream.newest):
                self._remove(actor_id, "far", stream.last_rx)
        # The snapshot came before we knew where we are: its egos near us count now.
        pending, self._snapshot_egos = self._snapshot_egos, []
        for ego, rx_t in pending:
            if ego.node_id in self.present and ego.node_id not in self.egos:
                self._snapshot_pose(ego, rx_t)

    def _on_snapshot(self, snapshot: Snapshot, rx_t: float) -> None:
        self.lights = self.lights or snapshot.lights
        self.weather = self.weather or snapshot.weather
        # With an interest area the tile batches bring the NPCs near us within a batch period.
        if snapshot.npc is not None and not self.npcs and self.interest is None:
            self._on_npc(snapshot.npc, rx_t)
        for ego in snapshot.egos:
            node_id = ego.node_id
            if node_id in (self.own_id, AUTHORITY_ID) or node_id in self._tombstones:
                continue
            self._admit(node_id)
            if ego.state is not None:
                self.ego_states.setdefault(node_id, ego.state)
            if self.interest is not None and not self.interest:
                self._snapshot_egos.append((ego, rx_t))  # our place is not known yet
            elif node_id not in self.egos:
                self._snapshot_pose(ego, rx_t)

    def _snapshot_pose(self, ego: EgoInfo, rx_t: float) -> None:
        pose = ego.pose
        if pose is not None and self.hears(pose):
            self._apply(self.streams.apply([ego.node_id], [pose], [rx_t]))
            if ego.node_id in self.egos:
                self.egos[ego.node_id].kind = ego.actor_kind

    def _on_state(self, node_id: str, state: EgoState) -> None:
        if node_id in self.present:
            self.ego_states[node_id] = state

    def _on_skeleton(self, node_id: str, skeleton: Skeleton) -> None:
        if node_id not in self.present:
            self.rejected["skeleton_from_absent_node"] += 1
        elif len(skeleton.angles) != 12 * len(skeleton.joints):  # 3 float32 per joint
            self.rejected["skeleton_size"] += 1
        elif node_id not in self.skeletons or skeleton.t >= self.skeletons[node_id].t:
            self.skeletons[node_id] = skeleton

    def _on_gone(self, node_id: str, reason: Departure, t: float) -> None:
        if reason == "left" and node_id in self._tombstones and node_id not in self.egos:
            self._amend_loss(node_id)
        self._tombstones[node_id] = t
        self.present.discard(node_id)
        self.streams.refuse(node_id)
        self._remove(node_id, reason, t)

    def _amend_loss(self, node_id: str) -> None:
        """A node's token loss heard before the authority's word that it left: it left.

        A leaving node drops its token only after it saw its own `left` event, but this view
        hears the two on different links (the event from the authority, the DELETE from the
        node), so under load the DELETE can come first. The authority's reason is the true one.
        """
        for k in range(len(self.despawns) - 1, -1, -1):
            record = self.despawns[k]
            if record.actor_id == node_id:
                if record.reason == "liveliness":
                    self.despawns[k] = Despawn(node_id, "left", record.t)
                return

    def _on_present(self, node_id: str) -> None:
        if node_id == AUTHORITY_ID:  # the authority is never an actor, whoever says so
            self.rejected["reserved_id"] += 1
            return
        self._tombstones.pop(node_id, None)
        self._admit(node_id)

    def _admit(self, node_id: str) -> None:
        self.present.add(node_id)
        self.streams.admit(node_id, STATS_LIMIT)

    def _remove(self, node_id: str, reason: Departure, t: float) -> None:
        if self.egos.close(node_id) is not None:
            self.despawns.append(Despawn(node_id, reason, t))
            log.info("despawned %s (%s)", node_id, reason)
        stream = self.streams.get(node_id)
        if reason == "far" and stream is not None:  # alive, only out of earshot: no loss
            stream.reset_statistics()
        self.ego_states.pop(node_id, None)
        self.skeletons.pop(node_id, None)

    def _forget_tombstones(self, now: float) -> None:
        if self._tombstones:
            for node_id in [n for n, t in self._tombstones.items() if now - t > TOMBSTONE_S]:
                del self._tombstones[node_id]

    # ------------------------------------------------------------ queries

    def render_time(self, now: float) -> float:
        """The one session time every actor of this view is drawn at, for a frame at `now`."""
        if self._render is not None and self._render[0] == now:
            return self._render[1]
        if self.render_mode == "present":
            render_t = now
        else:
            needs = [a.target_delay() for a in self.egos.values() if not a.is_stale(now)]
            if self.npcs and not self.npcs.is_stale(now):
                needs.append(self.npcs.timing.target_delay())
            target = max(needs) if needs else self._delay.delay_s
            render_t = now - self._delay.follow(target, now)
        self._render = (now, render_t)
        return render_t

    def ego_views(self, now: float) -> Iterator[ActorView]:
        render_t = self.render_time(now)
        present = self.render_mode == "present"
        for actor in self.egos.values():
            view = actor.present(now) if present else actor.past(render_t, now)
            if view is not None:
                yield view

    def npc_frame(self, now: float) -> NpcFrame | None:
        """Every NPC at this view's render time, as arrays; None before the first batch."""
        s = self.settings
        limit = s.max_projection_s if self.render_mode == "present" else s.max_extrapolation_s
        return self.npcs.frame(self.render_time(now), limit)

    def npc_views(self, now: float) -> Iterator[ActorView]:
        """The NPCs one by one (an object each: prefer `npc_frame` for many)."""
        frame = self.npc_frame(now)
        if frame is None:
            return
        stale = self.npcs.is_stale(now)
        for i, npc_id in enumerate(frame.ids):
            phase = Phase.EXTRAPOLATING if frame.extrapolated[i] else Phase.INTERPOLATING
            yield ActorView(
                npc_id, float(frame.x[i]), float(frame.y[i]), float(frame.z[i]), 0.0, 0.0,
                float(frame.yaw[i]), float(frame.vx[i]), float(frame.vy[i]), 0.0, phase,
                stale, frame.t,
            )  # fmt: skip
