"""`carlaverse view FILE.mcap`: render a recording as the live view would have.

Recorded samples go through the same store, model and scene as live ones, with the
recorder's receive time (MCAP log time) standing in for the local clock, and frames every
1/rate s of that time. Authority replies kept in the recording supply the map and extents.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from carlaverse.recording.reading import iter_samples
from carlaverse.viz.scene import SceneLogger
from carlaverse.viz.store import SampleStore
from carlaverse.viz.world import WorldModel

PLAUSIBLE_LATENCY_S = 10.0  # [s] above this (or below 0) the two clocks are not comparable


@dataclass(slots=True)
class PlaybackStats:
    samples: int = 0
    frames: int = 0


def _latency(rx_t: float, msg_t: float) -> float | None:
    """Log time is wall time; carlaverse session time is wall-aligned, a synthetic one not."""
    latency = rx_t - msg_t
    return latency if 0.0 <= latency < PLAUSIBLE_LATENCY_S else None


def render_recording(
    path: str | Path, scene: SceneLogger, rate_hz: float = 20.0, despawn_timeout_s: float = 5.0
) -> PlaybackStats:
    """Log a whole recording into `scene`'s stream; returns how much was rendered."""
    store, world, stats = SampleStore(), WorldModel(latency_of=_latency), PlaybackStats()
    period = 1.0 / rate_hz
    next_frame: float | None = None

    def frame(at: float) -> None:
        world.apply(store.take())
        world.newcomers = False
        world.expire(at, despawn_timeout_s)
        world.update_rates(at)
        scene.render(world)
        stats.frames += 1

    for sample in iter_samples(path):
        rx = sample.log_time_ns / 1e9
        next_frame = rx + period if next_frame is None else next_frame
        if rx >= next_frame:
            frame(next_frame)
            next_frame += period * (math.floor((rx - next_frame) / period) + 1)  # skip silence
        store.offer(sample.key, sample.payload, rx, sample.kind)
        stats.samples += 1
    if next_frame is not None:
        frame(next_frame)
    return stats
