"""What a node and its fabric are configured with: the `node:` and `fabric:` sections of a
config, as plain settings that import no Zenoh.

A node kind's config embeds these, and its loop process reads that config: a 90 Hz loop must
not load the network stack for two structs (`session` and `node_client` use them to open and
join).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec

from carlaverse import messages as m
from carlaverse.config import StrictStruct
from carlaverse.world.remote_actor import InterpolationSettings

Mode = Literal["peer", "client", "router"]


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
    # a path, and disables QoS priorities. It does not fragment: a message over Zenoh's batch
    # size (64 KiB; a large map or snapshot reply) is lost and the link to that peer closed.
    lowlatency: bool = False
    # Raw Zenoh config entries (json5 path -> value) for what has no field here: TLS files,
    # authentication, access control. Applied last.
    zenoh: dict[str, Any] = {}


class NodeSettings(StrictStruct):
    node_id: str = ""  # required; may come from --id instead of the file
    session: str = "default"
    kind: str = "scripted"
    actor_kind: str = "car"
    extent: m.Extent = m.Extent()
    mass_kg: float = 1500.0
    site: str = ""
    pose_rate_hz: float = 50.0
    join_retry_s: float = 0.5
    join_timeout_s: float = 2.0
    clock_sync_period_s: float = 2.0
    interpolation: InterpolationSettings = InterpolationSettings()
    # [m] hear the egos and NPCs within this distance (at least; whole tiles are heard).
    # 0 hears the whole session; a node without an actor (observer) always does.
    interest_radius_m: Annotated[float, msgspec.Meta(ge=0)] = 200.0
    # Run the pose callbacks on Zenoh's network thread: ~0.1 ms less per pose on an idle
    # host, more CPU per pose (see `Inbound.pose_handler`); part of the low-latency set-up
    # with `fabric: {lowlatency: true}`.
    direct_pose_callbacks: bool = False
    # Hear the whole session's poses through the authority's digest (`world/@egos`): dozens
    # of poses per sample instead of one each, for about 1 ms more delay; for a node that
    # hears the whole session (interest radius 0, or no actor). See docs/benchmarks.md.
    pose_digest: bool = False

    def __post_init__(self) -> None:
        if self.pose_digest and self.interest_radius_m > 0 and self.actor_kind:
            raise ValueError(
                "pose_digest carries the whole session's poses: set interest_radius_m: 0 "
                f"to use it (it is {self.interest_radius_m:g})"
            )
