"""What a node asks the authority (`authority/<query>`) and what it answers: join, leave,
clock, the snapshot, the map, the scenario, the nodes' configs."""

from __future__ import annotations

import msgspec

from carlaverse.messages.base import Finite, Int64, Time
from carlaverse.messages.codec import Codec
from carlaverse.messages.ego import EgoState
from carlaverse.messages.pose import Pose, decode_pose, encode_pose
from carlaverse.messages.world import LightsState, NpcBatch, Weather


class Extent(msgspec.Struct, frozen=True, array_like=True):
    length: Finite = 4.5  # [m]
    width: Finite = 1.8  # [m]
    height: Finite = 1.5  # [m]


# Typical extents per actor kind [m], for an actor whose own extent is not known.
KIND_EXTENTS: dict[str, Extent] = {
    "car": Extent(4.5, 1.8, 1.5),
    "van": Extent(5.2, 2.0, 2.3),
    "truck": Extent(9.0, 2.5, 3.4),
    "bus": Extent(12.0, 2.55, 3.1),
    "motorcycle": Extent(2.1, 0.8, 1.5),
    "bicycle": Extent(1.8, 0.6, 1.7),
    "pedestrian": Extent(0.5, 0.6, 1.75),
    "other": Extent(4.0, 1.8, 1.6),
}


class SpawnPoint(msgspec.Struct, frozen=True, array_like=True):
    x: Finite
    y: Finite
    z: Finite = 0.0
    yaw: Finite = 0.0


class JoinRequest(msgspec.Struct, frozen=True):
    schema: Int64
    node_id: str
    instance: str  # random per process run: tells a re-join from a duplicate id
    kind: str  # node kind: drive, bike, walk, scripted, observer ...
    actor_kind: str = "car"  # one of ACTOR_KINDS; observers have no actor
    extent: Extent = Extent()
    mass_kg: Finite = 1500.0
    site: str = ""
    hostname: str = ""
    version: str = ""
    pose_rate_hz: Finite = 50.0
    config_yaml: str = ""  # the node's effective config, archived with recordings


class JoinReply(msgspec.Struct, frozen=True):
    schema: Int64
    accepted: bool
    reason: str = ""
    session: str = ""
    spawn: SpawnPoint | None = None
    despawn_timeout_s: Finite = 3.0
    tick_hz: Finite = 50.0
    authority_instance: str = ""
    # [s] how often the authority relays the pose digest (`world/@egos`); 0: it relays none
    pose_digest_s: Finite = 0.0


class LeaveRequest(msgspec.Struct, frozen=True):
    """A node leaving on purpose, sent on `authority/leave` before it drops its token.

    `instance` must be the one the node joined with: only the joined process can make its id
    leave (the instance travels nowhere but in its own join request).
    """

    node_id: str
    instance: str


class LeaveReply(msgspec.Struct, frozen=True):
    left: bool  # False: the authority did not know this node (already gone, or not it)


class ClockRequest(msgspec.Struct, frozen=True):
    node_id: str = ""


class ClockReply(msgspec.Struct, frozen=True, array_like=True):
    t: Time  # [s] session time when the authority answered
    known: bool = False  # whether the asking node is currently joined


class EgoInfo(msgspec.Struct, frozen=True):
    """One joined node as the snapshot lists it.

    The pose travels in the one pose layout (`POSE_LAYOUT`, 64 bytes) under the wire name
    `pose`; `pose_wire` holds those bytes and `.pose` decodes them. For convenience a `Pose` may
    be passed where the bytes go; it is encoded on construction.
    """

    node_id: str
    kind: str
    actor_kind: str
    extent: Extent
    mass_kg: Finite
    site: str = ""
    pose_wire: bytes | None = msgspec.field(default=None, name="pose")
    state: EgoState | None = None

    def __post_init__(self) -> None:
        if isinstance(self.pose_wire, Pose):
            msgspec.structs.force_setattr(self, "pose_wire", encode_pose(self.pose_wire))
        elif self.pose_wire is not None:
            decode_pose(self.pose_wire)  # refuse a bad layout at decode time, with the reason

    @property
    def pose(self) -> Pose | None:
        return None if self.pose_wire is None else decode_pose(self.pose_wire)


class Snapshot(msgspec.Struct, frozen=True):
    schema: Int64
    t: Time
    egos: list[EgoInfo]
    npc: NpcBatch | None = None
    lights: LightsState | None = None
    weather: Weather | None = None


class MapLane(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # road | sidewalk | bike | crossing | walkingarea | rail
    width: Finite  # [m]
    centerline: list[tuple[Finite, Finite]]  # [m]
    allow: list[str] = []
    speed: Finite = 0.0  # [m/s] its speed limit (SUMO lane speed); 0 when not known
    change_left: bool = True  # a car may change from it to the lane on its left (changeLeft)
    change_right: bool = True  # a car may change from it to the lane on its right (changeRight)
    opposite: str = ""  # the oncoming lane beyond its left edge that may be used to overtake
    # What rules a vehicle at the lane's end, from SUMO's junction type and link states: signal |
    # major | yield | stop | allway_stop | right_before_left | left_before_right | zipper, or ""
    # for nothing (a dead end, a pedestrian lane); a receiver reads a word it does not know as "".
    right_of_way: str = ""  # what rules a vehicle at its end (Map lane rules, below)
    successors: list[str] = []  # the lanes its connections lead to, beyond the junction


class MapArea(msgspec.Struct, frozen=True, array_like=True):
    id: str
    kind: str  # junction | vegetation | water | building
    polygon: list[tuple[Finite, Finite]]


class MapLight(msgspec.Struct, frozen=True, array_like=True):
    id: str  # traffic light (SUMO tls) id
    position: tuple[Finite, Finite]
    controlled_lanes: list[str]  # one entry per link index of the light's state string


class MapReply(msgspec.Struct, frozen=True):
    schema: Int64
    name: str
    bounds: tuple[Finite, Finite, Finite, Finite]  # xmin, ymin, xmax, ymax [m]
    lanes: list[MapLane]
    areas: list[MapArea] = []
    lights: list[MapLight] = []


class ScenarioReply(msgspec.Struct, frozen=True):
    schema: Int64
    name: str
    yaml: str  # the scenario file as run, byte-for-byte
    seed: Int64 = 0


class ConfigsReply(msgspec.Struct, frozen=True):
    """Every joined node's effective config, for archiving with a recording."""

    schema: Int64
    nodes: dict[str, str]  # node id -> config YAML as the node sent it at join
    scenario_yaml: str = ""
    hostnames: dict[str, str] = {}  # node id -> host it joined from


JOIN_REQUEST: Codec[JoinRequest] = Codec(JoinRequest)
JOIN_REPLY: Codec[JoinReply] = Codec(JoinReply)
LEAVE_REQUEST: Codec[LeaveRequest] = Codec(LeaveRequest)
LEAVE_REPLY: Codec[LeaveReply] = Codec(LeaveReply)
CLOCK_REQUEST: Codec[ClockRequest] = Codec(ClockRequest)
CLOCK_REPLY: Codec[ClockReply] = Codec(ClockReply)
SNAPSHOT: Codec[Snapshot] = Codec(Snapshot)
MAP: Codec[MapReply] = Codec(MapReply)
SCENARIO: Codec[ScenarioReply] = Codec(ScenarioReply)
CONFIGS: Codec[ConfigsReply] = Codec(ConfigsReply)
