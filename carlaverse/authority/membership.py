"""Who is in the session: joins, presence tokens, telemetry staleness (DESIGN §5).

Pure bookkeeping, no network: the service feeds it joins, liveliness changes and pose
arrivals, and asks it each tick who must be despawned. A node is despawned when its presence
token disappears, or when it has an actor in the world and its telemetry is older than the
despawn timeout — the paper's fail-safe against stale actors causing phantom collisions.

A join for an id already taken is refused unless it comes from the same process (same
`instance`: a re-join after an authority restart or a partition) or the old holder is gone.
"""

from __future__ import annotations

from dataclasses import dataclass

from carlaverse.authority.domain import EgoTrack
from carlaverse.keys import AUTHORITY_ID, KeySpaceError, check_token
from carlaverse.messages import SCHEMA_VERSION, EgoInfo, JoinRequest, Pose


@dataclass(frozen=True, slots=True)
class JoinDecision:
    accepted: bool
    reason: str = ""
    track: EgoTrack | None = None
    new: bool = False  # a first join (announce a spawn) rather than a re-join


class Roster:
    def __init__(self, despawn_timeout_s: float) -> None:
        self.despawn_timeout_s = despawn_timeout_s
        self.tracks: dict[str, EgoTrack] = {}
        self.tokens: set[str] = set()

    def join(self, req: JoinRequest, t: float) -> JoinDecision:
        problem = self._check(req)
        if problem:
            return JoinDecision(False, problem)
        old = self.tracks.get(req.node_id)
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
            config_yaml=req.config_yaml,
            extra={"hostname": req.hostname, "version": req.version},
        )
        if old is not None and old.instance == req.instance:
            track.last_pose, track.last_rx_t = old.last_pose, old.last_rx_t
        self.tracks[req.node_id] = track
        return JoinDecision(True, track=track, new=old is None or old.instance != req.instance)

    def _check(self, req: JoinRequest) -> str:
        if req.schema != SCHEMA_VERSION:
            return (
                f"schema version {req.schema} does not match the authority's {SCHEMA_VERSION}; "
                "run the same carlaverse version on every node"
            )
        if req.node_id == AUTHORITY_ID:
            return f"node id {AUTHORITY_ID!r} is reserved for the authority"
        try:
            check_token(req.node_id)
        except KeySpaceError as exc:
            return str(exc)
        return ""

    def _holds(self, track: EgoTrack, t: float) -> bool:
        """Whether the current holder of an id still looks alive."""
        if track.node_id in self.tokens:
            return True
        last = track.last_rx_t if track.last_rx_t >= 0 else track.joined_t
        return t - last < self.despawn_timeout_s

    def pose(self, node_id: str, pose: Pose, rx_t: float) -> None:
        track = self.tracks.get(node_id)
        if track is not None and (track.last_pose is None or pose.t >= track.last_pose.t):
            track.last_pose, track.last_rx_t = pose, rx_t

    def token(self, node_id: str, alive: bool) -> bool:
        """Record a presence change; True if a joined node just lost its token."""
        if alive:
            self.tokens.add(node_id)
            return False
        self.tokens.discard(node_id)
        return node_id in self.tracks

    def remove(self, node_id: str) -> EgoTrack | None:
        return self.tracks.pop(node_id, None)

    def expired(self, t: float) -> list[str]:
        """Joined nodes with an actor whose telemetry is older than the despawn timeout."""
        out = []
        for node_id, track in self.tracks.items():
            if not track.info.actor_kind:
                continue  # observers publish no pose; presence alone keeps them
            last = track.last_rx_t if track.last_rx_t >= 0 else track.joined_t
            if t - last > self.despawn_timeout_s:
                out.append(node_id)
        return out
