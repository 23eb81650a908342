"""Who is in the session: joins, presence tokens, telemetry staleness (docs/architecture.md §6).

Pure bookkeeping, no network: the service feeds it joins, liveliness changes and pose
arrivals, and asks it each tick who must be despawned. A node is despawned when its presence
token disappears, or when it has an actor in the world and its telemetry is older than the
despawn timeout — the paper's fail-safe against stale actors causing phantom collisions.

A node without an actor (an observer) publishes no pose: it is kept by its liveliness token,
and despawned for silence once it has held none for the despawn timeout — a join that never
declares a token does not live forever.

A join for an id already taken is refused unless it comes from the same process (same
`instance`: a re-join after an authority restart or a partition) or the old holder is gone;
a new process taking over a gone holder's id replaces it (`replaced`: the authority removed
the old one). Every join is validated first (`carlaverse.authority.join_check`).
"""

from __future__ import annotations

from dataclasses import dataclass

from carlaverse.authority.domain import EgoTrack
from carlaverse.authority.join_check import join_problem
from carlaverse.messages import EgoInfo, JoinRequest, Pose
from carlaverse.redact import redact_yaml

MAX_NODES = 512  # joined nodes per session; beyond it a join is refused, not stored
MAX_TOKENS = 4096  # presence tokens remembered; more are not tracked (an id flood)
MAX_POSE_SKEW_S = 5.0  # [s] a pose this far from the authority's time is refused


@dataclass(frozen=True, slots=True)
class JoinDecision:
    accepted: bool
    reason: str = ""
    track: EgoTrack | None = None
    new: bool = False  # a first join (announce a spawn) rather than a re-join
    replaced: bool = False  # the id's previous holder (another process, gone) was removed


class Roster:
    def __init__(self, despawn_timeout_s: float, max_pose_skew_s: float = MAX_POSE_SKEW_S) -> None:
        self.despawn_timeout_s = despawn_timeout_s
        self.max_pose_skew_s = max_pose_skew_s
        self.tracks: dict[str, EgoTrack] = {}
        self.tokens: set[str] = set()

    def join(self, req: JoinRequest, t: float) -> JoinDecision:
        problem = join_problem(req)
        if problem:
            return JoinDecision(False, problem)
        old = self.tracks.get(req.node_id)
        if old is None and len(self.tracks) >= MAX_NODES:
            return JoinDecision(False, f"the session is full ({MAX_NODES} nodes)")
        if old is not None and old.instance != req.instance and self._holds(old, t):
            return JoinDecision(
                False,
                f"node id {req.node_id!r} is already in use by a {old.info.kind} node "
                f"from {old.extra.get('hostname') or 'another host'}; choose another --id",
            )
        track = EgoTrack(
            info=EgoInfo(req.node_id, req.kind, req.actor_kind, req.extent, req.mass_kg, req.site),
            instance=req.instance,
            joined_t=t,
            # Nodes redact before sending; an older or foreign node may not, and the authority
            # serves this text to every participant and recorder.
            config_yaml=redact_yaml(req.config_yaml),
            extra={"hostname": req.hostname, "version": req.version},
        )
        same_process = old is not None and old.instance == req.instance
        if same_process:
            track.last_pose, track.last_rx_t = old.last_pose, old.last_rx_t  # type: ignore[union-attr]
        self.tracks[req.node_id] = track
        return JoinDecision(
            True, track=track, new=not same_process, replaced=old is not None and not same_process
        )

    def _holds(self, track: EgoTrack, t: float) -> bool:
        """Whether the current holder of an id still looks alive."""
        if track.node_id in self.tokens:
            return True
        last = track.last_rx_t if track.last_rx_t >= 0 else track.joined_t
        return t - last < self.despawn_timeout_s

    def pose(self, node_id: str, pose: Pose, rx_t: float) -> str:
        """Apply a pose that arrived at session time rx_t; the reason if it was refused.

        A joined node stays alive with every plausible pose, even one older than the pose
        kept, so a forged pose from the near future cannot starve it into a timeout; and a
        kept pose from the future gives way to the next real one.
        """
        track = self.tracks.get(node_id)
        if track is None:
            return "not_joined"
        if abs(pose.t - rx_t) > self.max_pose_skew_s:
            return "implausible_time"
        track.last_rx_t = rx_t
        last = track.last_pose
        if last is None or pose.t >= last.t or last.t > rx_t:
            track.last_pose = pose
        return ""

    def token(self, node_id: str, alive: bool) -> bool:
        """Record a presence change; True if a joined node just lost its token."""
        if alive:
            if len(self.tokens) < MAX_TOKENS or node_id in self.tracks:
                self.tokens.add(node_id)
            return False
        self.tokens.discard(node_id)
        return node_id in self.tracks

    def remove(self, node_id: str) -> EgoTrack | None:
        return self.tracks.pop(node_id, None)

    def expired(self, t: float) -> list[str]:
        """Joined nodes silent for longer than the despawn timeout.

        Silent: for a node with an actor, no pose; for one without (an observer, which
        publishes none), no presence token since it joined.
        """
        return [node_id for node_id, track in self.tracks.items() if self._silent(track, t)]

    def _silent(self, track: EgoTrack, t: float) -> bool:
        if not track.info.actor_kind and track.node_id in self.tokens:
            return False
        last = track.last_rx_t if track.last_rx_t >= 0 else track.joined_t
        return t - last > self.despawn_timeout_s
