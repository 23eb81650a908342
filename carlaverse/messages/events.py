"""What happens in the world, as the authority tells it (`world/events`, a tagged union), and
the collision impulse it sends one ego (`impulse/<id>`)."""

from __future__ import annotations

from typing import Literal

import msgspec

from carlaverse.messages.base import Finite, Int64, Seq, Time, Vec3
from carlaverse.messages.codec import Codec


class Spawned(msgspec.Struct, frozen=True, tag="spawned"):
    """A node joined: its actor (if any) is in the world from now on."""

    seq: Seq
    t: Time
    node_id: str
    kind: str  # the node kind (drive, scripted, observer ...)
    actor_kind: str = ""  # one of ACTOR_KINDS; "" for a node without an actor (observer)


# Why a node left the session: it said so (`authority/leave`); its liveliness token was lost
# (lease expiry, a crash); its telemetry went silent for the despawn timeout; the authority
# removed it (a re-join from a new process under the same id replaces the old one).
DespawnReason = Literal["left", "liveliness", "timeout", "authority"]


class Despawned(msgspec.Struct, frozen=True, tag="despawned"):
    """A node left the world, and why."""

    seq: Seq
    t: Time
    node_id: str
    reason: DespawnReason


class ContactStarted(msgspec.Struct, frozen=True, tag="contact_started"):
    """Two actors' boxes began to touch (one contact, until it ends)."""

    seq: Seq
    t: Time
    contact_id: Int64
    a: str
    b: str
    relative_speed_mps: Finite = 0.0


class ContactEnded(msgspec.Struct, frozen=True, tag="contact_ended"):
    """Two actors' boxes no longer touch."""

    seq: Seq
    t: Time
    contact_id: Int64
    a: str
    b: str


class TriggerFired(msgspec.Struct, frozen=True, tag="trigger"):
    """A scenario trigger's condition held and its actions ran (recorded for the analysis)."""

    seq: Seq
    t: Time
    trigger_id: str
    actions: list[str]  # what was done, e.g. "release waiting-car", "light C GrGr"
    # the trigger's measurements when it fired; None where not finite (no ETA, no TTC)
    values: dict[str, Finite | None] = {}


class Notice(msgspec.Struct, frozen=True, tag="notice"):
    """Text for a participant's HMI, from a scenario trigger."""

    seq: Seq
    t: Time
    text: str
    to: str = ""  # a node id, or "" for every participant
    duration_s: Finite = 5.0  # [s] how long it stays up


WorldEvent = Spawned | Despawned | ContactStarted | ContactEnded | TriggerFired | Notice


class Impulse(msgspec.Struct, frozen=True):
    """Collision impulse for one ego, decided by the authority."""

    seq: Seq
    t: Time  # [s] session time at which to apply it
    contact_id: Int64
    impulse: Vec3  # [N·s] world frame, acting on this ego
    point: Vec3  # [m] contact point, world frame
    normal: Vec3  # unit, pointing from the other actor into this ego
    other_id: str
    other_kind: str
    relative_speed_mps: Finite


WORLD_EVENT: Codec[WorldEvent] = Codec(WorldEvent)
IMPULSE: Codec[Impulse] = Codec(Impulse)
