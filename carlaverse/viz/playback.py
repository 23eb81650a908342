"""`carlaverse view FILE.mcap`: render a recording as the live view would have.

Recorded samples go through the same store, model, world view and scene as live ones, in
receive order, with the recorder's receive time (MCAP log time) standing in for the receive
time, and frames every 1/rate s of that time: the view interpolates (one render time per
frame) from what had arrived by then, exactly as it would have live. Authority replies kept in
the recording supply the map and extents.

Receive times must be session times for the view. A carlaverse session's time is wall-aligned,
so log time is used as it is when the first pose's log time minus its own time is a plausible
latency; otherwise (a synthetic session, a clock far off) log times are moved onto the session
clock by that difference, and latencies are not shown, since they could not be measured.

Beside `sim_time` everything is on a second timeline, `from_start`: seconds from the
recording's first sample, the number `carlaverse render --at`, `audio render --at` and the
analysis report use, so a moment found in one is found in the others. `FromStart` stamps it
wherever the scene stamps session time, so the two always name the same instant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rerun as rr

from carlaverse.keys import KeySpaceError, parse_cached
from carlaverse.recording.reading import iter_samples
from carlaverse.recording.timeline import first_pose
from carlaverse.viz.live import VIEW_ID, viewer_interpolation
from carlaverse.viz.model import WorldModel
from carlaverse.viz.raw import ActorFeed
from carlaverse.viz.scene import SceneLogger
from carlaverse.viz.store import SampleStore
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.source import SampleFeed
from carlaverse.world.world_view import WorldView

PLAUSIBLE_LATENCY_S = 10.0  # [s] above this (or below 0) the two clocks are not comparable
ACTOR_CHANNELS = {("ego", "pose"), ("world", "npc")}
FROM_START = "from_start"  # the Rerun timeline of seconds from the recording's start
SESSION_TIMELINE = "sim_time"  # the scene's timeline of session seconds


@dataclass(slots=True)
class PlaybackStats:
    samples: int = 0
    frames: int = 0
    start: float = math.nan  # [s] receive time of the first sample, on the view's clock
    end: float = math.nan  # [s] receive time of the last sample, on the same clock

    @property
    def span_s(self) -> float:
        """[s] from the recording's first sample to its last (0 for an empty one)."""
        return self.end - self.start if self.samples else 0.0


def _latency(rx_t: float, msg_t: float) -> float | None:
    latency = rx_t - msg_t
    return latency if 0.0 <= latency < PLAUSIBLE_LATENCY_S else None


def receive_offset(path: str | Path) -> tuple[float, bool]:
    """[s] log time − session time, and whether the two clocks were comparable."""
    pose = first_pose(path)
    if pose is None:
        return 0.0, True
    offset = (pose.log_time_ns - pose.publish_time_ns) / 1e9
    comparable = 0.0 <= offset < PLAUSIBLE_LATENCY_S
    return (0.0 if comparable else offset), comparable


class FromStart:
    """A Rerun recording stream whose every session-time stamp (`sim_time`) also goes on the
    `from_start` timeline, as seconds after `origin` [s, session time]; all else passes
    through to the stream."""

    def __init__(self, rec: rr.RecordingStream, origin: float) -> None:
        self._rec = rec
        self.origin = origin

    def set_time(self, timeline: str, **stamp: float) -> None:
        self._rec.set_time(timeline, **stamp)
        if timeline == SESSION_TIMELINE and "duration" in stamp:
            self._rec.set_time(FROM_START, duration=stamp["duration"] - self.origin)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rec, name)


def view_origin(path: str | Path) -> float:
    """[s] the recording's first sample on the clock the view runs on (`receive_offset`)."""
    first = next(iter_samples(path), None)
    return 0.0 if first is None else first.log_time_ns / 1e9 - receive_offset(path)[0]


def render_recording(
    path: str | Path,
    scene: SceneLogger,
    rate_hz: float = 20.0,
    interpolation: InterpolationSettings | None = None,
) -> PlaybackStats:
    """Log a whole recording into `scene`'s stream; returns how much was rendered."""
    offset, comparable = receive_offset(path)
    view = WorldView(VIEW_ID, interpolation or viewer_interpolation())
    samples = SampleFeed(view.intake)
    feed = ActorFeed(samples, scene.raw)
    store, stats = SampleStore(), PlaybackStats()
    world = WorldModel(samples, latency_of=_latency if comparable else None)
    period = 1.0 / rate_hz
    next_frame: float | None = None

    def frame(at: float) -> None:
        world.apply(store.take())
        world.newcomers = False
        view.update(at)
        world.update_rates(at)
        scene.render(world, view, at)
        stats.frames += 1

    for sample in iter_samples(path):
        rx = sample.log_time_ns / 1e9 - offset
        stats.start = rx if stats.samples == 0 else stats.start
        stats.end = rx
        next_frame = rx + period if next_frame is None else next_frame
        if rx >= next_frame:
            frame(next_frame)
            next_frame += period * (math.floor((rx - next_frame) / period) + 1)  # skip silence
        store.offer(sample.key, sample.payload, rx, sample.kind)
        _feed_actor(feed, sample.key, sample.payload, rx)
        stats.samples += 1
    if next_frame is not None:
        frame(next_frame)
    return stats


def _feed_actor(feed: ActorFeed, key: str, payload: bytes, rx_t: float) -> None:
    try:
        parsed = parse_cached(key)
    except KeySpaceError:
        return  # the store counts unknown keys
    if (parsed.area, parsed.channel) in ACTOR_CHANNELS:  # the rest goes through the model
        feed.offer(key, payload, rx_t)
