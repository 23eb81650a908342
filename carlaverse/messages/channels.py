"""What travels on each key: the codec for every (area, channel) and for every query payload.
Recorders, validators and `carlaverse schema` look message types up here."""

from __future__ import annotations

from typing import Any

from carlaverse.keys import DIGEST_CHANNEL
from carlaverse.messages.audio import AUDIO_SCENE
from carlaverse.messages.codec import Codec
from carlaverse.messages.ego import EGO_STATE, OVERRIDE, SKELETON
from carlaverse.messages.events import IMPULSE, WORLD_EVENT
from carlaverse.messages.pose import POSE
from carlaverse.messages.pose_rows import POSE_DIGEST
from carlaverse.messages.queries import (
    CLOCK_REPLY,
    CLOCK_REQUEST,
    CONFIGS,
    JOIN_REPLY,
    JOIN_REQUEST,
    LEAVE_REPLY,
    LEAVE_REQUEST,
    MAP,
    SCENARIO,
    SNAPSHOT,
)
from carlaverse.messages.study import QUESTIONNAIRE_ANSWERS, QUESTIONNAIRE_REQUEST, TRIAL_BRIEF
from carlaverse.messages.world import LIGHTS, NPC_BATCH, WEATHER

# What travels on each key (area, channel) — recorders and validators look types up here.
CHANNEL_CODECS: dict[tuple[str, str], Codec[Any]] = {
    ("ego", "pose"): POSE,
    ("ego", "state"): EGO_STATE,
    ("ego", "override"): OVERRIDE,
    ("ego", "skeleton"): SKELETON,
    ("world", "npc"): NPC_BATCH,
    ("world", DIGEST_CHANNEL): POSE_DIGEST,
    ("world", "lights"): LIGHTS,
    ("world", "weather"): WEATHER,
    ("world", "events"): WORLD_EVENT,
    ("impulse", ""): IMPULSE,
    ("audio", ""): AUDIO_SCENE,
    ("authority", "join"): JOIN_REPLY,
    ("authority", "leave"): LEAVE_REPLY,
    ("authority", "clock"): CLOCK_REPLY,
    ("authority", "snapshot"): SNAPSHOT,
    ("authority", "map"): MAP,
    ("authority", "scenario"): SCENARIO,
    ("authority", "configs"): CONFIGS,
    ("study", "ask"): QUESTIONNAIRE_REQUEST,
    ("study", "answers"): QUESTIONNAIRE_ANSWERS,
    ("study", "brief"): TRIAL_BRIEF,
}

# What the authority's queryables expect as the query payload (the requests).
REQUEST_CODECS: dict[str, Codec[Any]] = {
    "join": JOIN_REQUEST,
    "leave": LEAVE_REQUEST,
    "clock": CLOCK_REQUEST,
}
