"""Every message on the fabric, as frozen msgspec Structs, with codecs built once
(docs/architecture.md §4). This package is the one place every message type is defined; each
module holds one family, and this module re-exports them all, so `carlaverse.messages.X` is
the name to use:

    base        the schema version, MessageError, the constrained wire types (Finite, Time ...)
    codec       Codec: one type's encoder and decoder, raising only MessageError
    pose        the 64-byte pose: layout, Pose, encode_pose / decode_pose, its codec
    pose_rows   many poses at once: numpy columns, decode_pose_rows, the pose digest
    ego         an ego's state, an ADAS override, a walker's skeleton; the LIGHT_* bits
    world       NPC batches, traffic lights, weather
    events      world events (a tagged union) and collision impulses
    audio       the audio scene one listener hears
    queries     the authority's queries and replies: join, leave, clock, snapshot, map ...
    study       questionnaires and their answers, a study's trial brief
    channels    what travels on each key: CHANNEL_CODECS, REQUEST_CODECS

Each module imports only those above it in this list.

Wire format: MessagePack. Structs that travel at high rate are `array_like` (no field names on
the wire); the rest encode as maps so new fields can be added with defaults (msgspec schema
evolution: new fields go last and carry a default). The pose is the one exception: it has a
fixed 64-byte little-endian layout (`POSE_LAYOUT`), because msgspec writes every float as
8 bytes and the pose is the hottest message of all.

Conventions: world frame = the road network's frame (x east, y north, z up, metres); angles in
radians, yaw counter-clockwise from +x; times are session seconds (the authority's clock).

Decoding network input never raises anything but `MessageError` (a ValueError), whatever is
wrong with it: malformed MessagePack, deep nesting, bad UTF-8, a value out of range — even in a
field this version does not know. Every float on the wire is finite and every integer fits an
int64 (the constrained types in `base`); a message that cannot be encoded raises
`MessageError` too.
"""

from __future__ import annotations

# isort: off
# In the order of the list above, not alphabetical: the Structs appear in this package's
# namespace in the order they are imported here, which is the order `carlaverse schema` and
# docs/protocol.md present them in (family by family, each family in its module's order;
# tests/transport/test_messages_package.py holds it).
from carlaverse.messages.base import (
    SCHEMA_VERSION,
    MessageError,
    FLOAT_LIMIT,
    TIME_LIMIT_S,
    Finite,
    Time,
    Seq,
    Int64,
    Vec3,
)
from carlaverse.messages.codec import (
    Codec,
)
from carlaverse.messages.pose import (
    POSE_LAYOUT_VERSION,
    POSE_LAYOUT,
    POSE_SIZE,
    POSE_FLAG_TELEPORT,
    Pose,
    encode_pose,
    decode_pose,
    pose_or_refusal,
    pose_stamp,
    PoseCodec,
    POSE,
)
from carlaverse.messages.pose_rows import (
    POSE_DTYPE,
    PoseColumns,
    pose_columns,
    pose_stamps,
    FEW_ROWS,
    decode_pose_rows,
    DIGEST_MAX_POSES,
    PoseDigest,
    POSE_DIGEST,
)
from carlaverse.messages.ego import (
    Indicator,
    LIGHT_PARKING,
    LIGHT_LOW_BEAM,
    LIGHT_HIGH_BEAM,
    LIGHT_FOG,
    LIGHT_BRAKE,
    LIGHT_REVERSE,
    LIGHT_INTERIOR,
    LIGHT_LEFT_BLINKER,
    LIGHT_RIGHT_BLINKER,
    EgoState,
    Override,
    Skeleton,
    EGO_STATE,
    OVERRIDE,
    SKELETON,
)
from carlaverse.messages.world import (
    ACTOR_KINDS,
    NPC_DTYPE,
    NpcBatch,
    TrafficLight,
    LightsState,
    Weather,
    NPC_BATCH,
    LIGHTS,
    WEATHER,
)
from carlaverse.messages.events import (
    Spawned,
    DespawnReason,
    Despawned,
    ContactStarted,
    ContactEnded,
    TriggerFired,
    Notice,
    WorldEvent,
    Impulse,
    WORLD_EVENT,
    IMPULSE,
)
from carlaverse.messages.audio import (
    AudioKind,
    AUDIO_KINDS,
    SIREN_PATTERNS,
    AUDIO_LEVEL_LIMIT_DB,
    AUDIO_MAX_EMITTERS,
    AUDIO_MAX_RPM,
    AUDIO_DRIVE_MEANING,
    Level,
    NonNegative,
    AudioEmitter,
    AudioScene,
    AUDIO_SCENE,
)
from carlaverse.messages.queries import (
    Extent,
    KIND_EXTENTS,
    SpawnPoint,
    JoinRequest,
    JoinReply,
    LeaveRequest,
    LeaveReply,
    ClockRequest,
    ClockReply,
    EgoInfo,
    Snapshot,
    MapLane,
    MapArea,
    MapLight,
    MapReply,
    ScenarioReply,
    ConfigsReply,
    JOIN_REQUEST,
    JOIN_REPLY,
    LEAVE_REQUEST,
    LEAVE_REPLY,
    CLOCK_REQUEST,
    CLOCK_REPLY,
    SNAPSHOT,
    MAP,
    SCENARIO,
    CONFIGS,
)
from carlaverse.messages.study import (
    QUESTIONNAIRE_MAX_ITEMS,
    QUESTIONNAIRE_MAX_POINTS,
    QUESTIONNAIRE_MAX_TEXT,
    StudyId,
    ShortText,
    LongText,
    ScaleValue,
    QuestionnaireItem,
    QuestionnaireRequest,
    QuestionnaireAnswers,
    QUESTIONNAIRE_REQUEST,
    QUESTIONNAIRE_ANSWERS,
    STUDY_BRIEF_MAX_CONFIG,
    TrialBrief,
    TRIAL_BRIEF,
)
from carlaverse.messages.channels import (
    CHANNEL_CODECS,
    REQUEST_CODECS,
)
# isort: on

__all__ = [
    "ACTOR_KINDS",
    "AUDIO_DRIVE_MEANING",
    "AUDIO_KINDS",
    "AUDIO_LEVEL_LIMIT_DB",
    "AUDIO_MAX_EMITTERS",
    "AUDIO_MAX_RPM",
    "AUDIO_SCENE",
    "CHANNEL_CODECS",
    "CLOCK_REPLY",
    "CLOCK_REQUEST",
    "CONFIGS",
    "DIGEST_MAX_POSES",
    "EGO_STATE",
    "FEW_ROWS",
    "FLOAT_LIMIT",
    "IMPULSE",
    "JOIN_REPLY",
    "JOIN_REQUEST",
    "KIND_EXTENTS",
    "LEAVE_REPLY",
    "LEAVE_REQUEST",
    "LIGHTS",
    "LIGHT_BRAKE",
    "LIGHT_FOG",
    "LIGHT_HIGH_BEAM",
    "LIGHT_INTERIOR",
    "LIGHT_LEFT_BLINKER",
    "LIGHT_LOW_BEAM",
    "LIGHT_PARKING",
    "LIGHT_REVERSE",
    "LIGHT_RIGHT_BLINKER",
    "MAP",
    "NPC_BATCH",
    "NPC_DTYPE",
    "OVERRIDE",
    "POSE",
    "POSE_DIGEST",
    "POSE_DTYPE",
    "POSE_FLAG_TELEPORT",
    "POSE_LAYOUT",
    "POSE_LAYOUT_VERSION",
    "POSE_SIZE",
    "QUESTIONNAIRE_ANSWERS",
    "QUESTIONNAIRE_MAX_ITEMS",
    "QUESTIONNAIRE_MAX_POINTS",
    "QUESTIONNAIRE_MAX_TEXT",
    "QUESTIONNAIRE_REQUEST",
    "REQUEST_CODECS",
    "SCENARIO",
    "SCHEMA_VERSION",
    "SIREN_PATTERNS",
    "SKELETON",
    "SNAPSHOT",
    "STUDY_BRIEF_MAX_CONFIG",
    "TIME_LIMIT_S",
    "TRIAL_BRIEF",
    "WEATHER",
    "WORLD_EVENT",
    "AudioEmitter",
    "AudioKind",
    "AudioScene",
    "ClockReply",
    "ClockRequest",
    "Codec",
    "ConfigsReply",
    "ContactEnded",
    "ContactStarted",
    "DespawnReason",
    "Despawned",
    "EgoInfo",
    "EgoState",
    "Extent",
    "Finite",
    "Impulse",
    "Indicator",
    "Int64",
    "JoinReply",
    "JoinRequest",
    "LeaveReply",
    "LeaveRequest",
    "Level",
    "LightsState",
    "LongText",
    "MapArea",
    "MapLane",
    "MapLight",
    "MapReply",
    "MessageError",
    "NonNegative",
    "Notice",
    "NpcBatch",
    "Override",
    "Pose",
    "PoseCodec",
    "PoseColumns",
    "PoseDigest",
    "QuestionnaireAnswers",
    "QuestionnaireItem",
    "QuestionnaireRequest",
    "ScaleValue",
    "ScenarioReply",
    "Seq",
    "ShortText",
    "Skeleton",
    "Snapshot",
    "SpawnPoint",
    "Spawned",
    "StudyId",
    "Time",
    "TrafficLight",
    "TrialBrief",
    "TriggerFired",
    "Vec3",
    "Weather",
    "WorldEvent",
    "decode_pose",
    "decode_pose_rows",
    "encode_pose",
    "pose_columns",
    "pose_or_refusal",
    "pose_stamp",
    "pose_stamps",
]
