"""The `audio:` config of a listening node, or of an offline render (configs/audio/*.yaml).

carlaverse join drive --audio headphones          # configs/audio/headphones.yaml
carlaverse audio render lab.mcap --listener car-1 --out car-1.wav --config ring8
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.patterns import anchored

Positive = Annotated[float, msgspec.Meta(gt=0.0)]
# Headphones (HRTF) or a speaker layout; `ringN` is N speakers evenly round the listener.
LAYOUTS_IN_WORDS = "binaural, stereo, quad, 5.1 or ringN (N speakers in a ring, 3 to 64)"
LAYOUT_PATTERN = anchored(
    r"binaural|stereo|quad|5\.1|ring([3-9]|[1-5][0-9]|6[0-4])", words=LAYOUTS_IN_WORDS
)
Layout = Annotated[str, msgspec.Meta(pattern=LAYOUT_PATTERN)]


class AirConfig(StrictStruct, frozen=True):
    """The air the sound travels through (ISO 9613-1 absorption, speed of sound)."""

    temperature_c: Annotated[float, msgspec.Meta(ge=-20.0, le=50.0)] = 20.0  # [°C]
    humidity_percent: Annotated[float, msgspec.Meta(ge=1.0, le=100.0)] = 70.0  # [%] relative
    pressure_kpa: Annotated[float, msgspec.Meta(ge=50.0, le=110.0)] = 101.325  # [kPa]


class ListenerConfig(StrictStruct, frozen=True):
    """Where the ears are: a tracked XR head when the node has one (the walk node's state),
    else the ego's pose plus the head's offset in it."""

    # Head centre in the vehicle frame (x forward, y left, z up) [m]: a driver's seat.
    head_offset_m: tuple[float, float, float] = (0.2, 0.35, 1.2)
    # The own engine, also in the vehicle frame [m]; heard when the node reports rpm.
    engine_offset_m: tuple[float, float, float] = (1.6, 0.0, 0.6)
    own_engine_level_db: float = 72.0  # [dB SPL at 1 m] own engine at full load


class OutputConfig(StrictStruct, frozen=True):
    """Where blocks go: a PortAudio device, or the simulated device (tests, headless)."""

    backend: Literal["sounddevice", "sim"] = "sounddevice"
    device: str | int | None = None  # PortAudio device name or index; None = the default
    prefill_blocks: Annotated[int, msgspec.Meta(ge=1, le=64)] = 3  # queued ahead [blocks]
    wav: str | None = None  # sim only: also write what it plays to this WAV (tests, demos)
    # SCHED_FIFO priority of the audio process where allowed (else nice −10); 0 = unchanged.
    realtime_priority: Annotated[int, msgspec.Meta(ge=0, le=99)] = 30


class AudioConfig(StrictStruct, frozen=True):
    """Everything the renderer needs; every field has a default that works on headphones."""

    layout: Layout = "binaural"
    # `kemar` = the MIT KEMAR set shipped in the `slab` package; else a SOFA file path.
    hrtf: str = "kemar"
    sample_rate_hz: Annotated[int, msgspec.Meta(ge=8000, le=192000)] = 48000
    block_size: Annotated[int, msgspec.Meta(ge=64, le=8192)] = 512  # [samples]
    max_emitters: Annotated[int, msgspec.Meta(ge=1, le=256)] = 64
    max_distance_m: Annotated[float, msgspec.Meta(gt=1.0, le=5000.0)] = 400.0  # [m] delay line
    # The sound pressure level that maps to an RMS of 1.0 in the output; the volume knob.
    full_scale_db_spl: float = 100.0  # [dB SPL]
    glide_s: Positive = 0.05  # [s] drive values follow the 20 Hz updates this smoothly
    stale_after_s: Positive = 0.5  # [s] no scene for this long: every emitter fades out
    seed: int = 0
    air: AirConfig = AirConfig()
    listener: ListenerConfig = ListenerConfig()
    output: OutputConfig = OutputConfig()
