"""What one listener can hear: the audio scene the authority computes per node
(docs/architecture.md §14)."""

from __future__ import annotations

from typing import Annotated, Literal, get_args

import msgspec

from carlaverse.messages.base import FLOAT_LIMIT, Finite, MessageError, Seq, Time
from carlaverse.messages.codec import Codec

# What makes a sound (docs/architecture.md §14). Point sources (engine, tyres, siren) sit on an
# actor; area sources (construction, leaves, water) sit at the point of their area nearest the
# listener with `extent_m` its radius; weather sources (rain, wind) surround the listener.
AudioKind = Literal["engine", "tyres", "siren", "construction", "leaves", "water", "rain", "wind"]
AUDIO_KINDS: tuple[str, ...] = get_args(AudioKind)
# Siren patterns (`drive_a` of a siren): how the renderer sweeps its tone.
SIREN_PATTERNS = ("wail", "yelp", "hi-lo")
AUDIO_LEVEL_LIMIT_DB = 200.0  # [dB SPL] far above any real source (a jet at 1 m is ~150 dB)
AUDIO_MAX_EMITTERS = 256  # per scene; the authority's per-node cap is far lower (config)
AUDIO_MAX_RPM = 30_000.0  # [1/min]
# What `drive_a` and `drive_b` mean, per kind; "-" = unused, sent as 0.
AUDIO_DRIVE_MEANING: dict[str, tuple[str, str]] = {
    "engine": ("engine speed [rpm]", "load 0..1"),
    "tyres": ("rolling speed [m/s]", "road wetness 0..1"),
    "siren": ("pattern: index into SIREN_PATTERNS", "-"),
    "construction": ("intensity 0..1", "-"),
    "leaves": ("intensity 0..1", "-"),
    "water": ("intensity 0..1", "-"),
    "rain": ("intensity 0..1", "-"),
    "wind": ("intensity 0..1", "-"),
}
Level = Annotated[float, msgspec.Meta(ge=-AUDIO_LEVEL_LIMIT_DB, le=AUDIO_LEVEL_LIMIT_DB)]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0, le=FLOAT_LIMIT)]


# gc=False: hundreds are made per audio instant and they hold no references (no cycles), so
# keeping them out of the cycle collector spares the authority's tick its collection pauses.
class AudioEmitter(msgspec.Struct, frozen=True, array_like=True, gc=False):
    """One sound source for one listener; `drive_a`/`drive_b` mean what AUDIO_DRIVE_MEANING says."""

    id: str  # stable per source across scenes, e.g. "veh12.engine"
    kind: AudioKind
    x: Finite  # [m] world frame
    y: Finite  # [m]
    z: Finite  # [m]
    vx: Finite  # [m/s] world frame (Doppler)
    vy: Finite  # [m/s]
    vz: Finite  # [m/s]
    level_db: Level  # [dB SPL] sound pressure level at 1 m from the source
    extent_m: NonNegative = 0.0  # [m] radius of an area source; 0 = a point
    drive_a: Finite = 0.0  # kind-specific, see AUDIO_DRIVE_MEANING
    drive_b: Finite = 0.0  # kind-specific, see AUDIO_DRIVE_MEANING


class AudioScene(msgspec.Struct, frozen=True):
    """What one listener can hear at one instant, loudest first, on `audio/<listener>` (~20 Hz)."""

    seq: Seq
    t: Time
    listener: str  # the node id this scene was computed for (= the key's id)
    emitters: list[AudioEmitter] = []


def _check_audio_scene(scene: AudioScene) -> None:
    if len(scene.emitters) > AUDIO_MAX_EMITTERS:
        raise MessageError(f"audio scene: {len(scene.emitters)} emitters, "
                           f"at most {AUDIO_MAX_EMITTERS}")  # fmt: skip
    for e in scene.emitters:
        _check_drive(e)


_UNIT_RANGE = (0.0, 1.0)
_DRIVE_RANGES: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "engine": ((0.0, AUDIO_MAX_RPM), _UNIT_RANGE),
    "tyres": ((0.0, FLOAT_LIMIT), _UNIT_RANGE),
    "siren": ((0.0, len(SIREN_PATTERNS) - 1), (0.0, 0.0)),
}


def _check_drive(e: AudioEmitter) -> None:
    """Each kind's drive values in their documented range (the renderer relies on it)."""
    ranges = _DRIVE_RANGES.get(e.kind, (_UNIT_RANGE, (0.0, 0.0)))
    for name, value, (low, high) in (("drive_a", e.drive_a, ranges[0]),
                                     ("drive_b", e.drive_b, ranges[1])):  # fmt: skip
        if not low <= value <= high:
            raise MessageError(f"audio emitter {e.id!r} ({e.kind}): {name} = {value!r} "
                               f"is outside [{low:g}, {high:g}]")  # fmt: skip
    if e.kind == "siren" and e.drive_a != int(e.drive_a):
        raise MessageError(f"audio emitter {e.id!r}: siren pattern {e.drive_a!r} is not an index")


AUDIO_SCENE: Codec[AudioScene] = Codec(AudioScene, _check_audio_scene)
