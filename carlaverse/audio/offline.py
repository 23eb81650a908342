"""Render a recording's audio for one listener into a WAV file.

    summary = render_recording("lab.mcap", "car-1", "car-1.wav", AudioConfig(layout="5.1"))

The listener's scenes (`audio/<id>`) and ego poses (`ego/<id>/pose`) are read from the
recording; the renderer runs on session time from the first scene to the last (plus the
time the farthest sound needs to arrive), or over the window asked for, taking each scene at
its own time and the ears where the poses put them. The summary says where the WAV begins in
seconds from the recording's start, the number `--at` takes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from carlaverse import messages as m
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.listener import ListenerPose
from carlaverse.audio.renderer import Renderer, build_renderer
from carlaverse.audio.track import PoseTrack
from carlaverse.audio.wav import WavWriter
from carlaverse.keys import KeySpaceError, parse
from carlaverse.recording.reading import iter_samples
from carlaverse.recording.timeline import recording_start_time

TAIL_S = 0.1  # [s] rendered after the emitters of the last scene have faded out
PROGRESS_BLOCKS = 200  # blocks between progress reports (about 2 s of audio)


class NothingToRender(ValueError):
    """The recording holds no audio (or no pose) for the asked listener; says what it has."""


@dataclass
class RecordedAudio:
    """What a recording holds for one listener."""

    scenes: list[m.AudioScene] = field(default_factory=list)
    poses: list[m.Pose] = field(default_factory=list)
    listeners: set[str] = field(default_factory=set)  # every id with audio in the file
    bad_scenes: int = 0


@dataclass
class RenderSummary:
    listener: str
    out: str
    layout: str
    channels: int
    seconds: float
    scenes: int
    emitters_max: int
    clipped_samples: int
    limited_blocks: int
    dropped: dict[str, int]
    at: float = 0.0  # [s] the WAV's first sample from the recording's start
    recording_start: float = 0.0  # [s] session time of the recording's first sample


Progress = Callable[[float, float], None]  # (fraction rendered, session time [s] reached)


def read_audio(path: str | Path, listener: str) -> RecordedAudio:
    """The listener's scenes and poses, in recorded order."""
    found = RecordedAudio()
    for sample in iter_samples(path):
        try:
            key = parse(sample.key)
        except KeySpaceError:
            continue
        if key.area == "audio":
            found.listeners.add(key.node_id)
        if key.node_id != listener or sample.kind != "put":
            continue
        try:
            if key.area == "audio":
                found.scenes.append(m.AUDIO_SCENE.decode(sample.payload))
            elif key.area == "ego" and key.channel == "pose":
                found.poses.append(m.decode_pose(sample.payload))
        except m.MessageError:
            found.bad_scenes += key.area == "audio"
    return found


def render_recording(path: str | Path, listener: str, out: str | Path, config: AudioConfig,
                     progress: Progress | None = None, *, start: float | None = None,
                     duration: float | None = None) -> RenderSummary:  # fmt: skip
    """Render `listener`'s audio of the recording at `path` into the WAV `out`, from session
    time `start` (default: the first scene) for `duration` [s] (default: until the last
    scene has faded out)."""
    recorded = read_audio(path, listener)
    track = _check(recorded, listener, path)
    scenes = sorted(recorded.scenes, key=lambda s: s.t)
    begin = scenes[0].t if start is None else start
    stop = scenes[-1].t + config.stale_after_s + TAIL_S
    stop = stop if duration is None else min(begin + duration, stop)
    scenes = _sounding_from(scenes, begin)
    origin = recording_start_time(path)
    if stop <= begin:
        raise NothingToRender(f"{path}: audio/{listener} has faded out by {begin - origin:.2f} s "
                              f"from start (its last scene is at "
                              f"{recorded.scenes[-1].t - origin:.2f} s)")  # fmt: skip
    renderer = build_renderer(config)
    head = config.listener.head_offset_m
    with WavWriter(out, renderer.channels, config.sample_rate_hz) as wav:
        play_scenes(renderer, scenes, stop, wav.write, lambda t: track.listener(t, head),
                    progress, start=begin)  # fmt: skip
    seconds = round(wav.frames / config.sample_rate_hz, 3)
    return RenderSummary(
        listener, str(out), config.layout, renderer.channels, seconds, len(scenes),
        max(len(s.emitters) for s in scenes), wav.clipped, renderer.limiter.blocks_limited,
        dict(renderer.slots.dropped), round(begin - origin, 6), origin,
    )  # fmt: skip


def _sounding_from(scenes: list[m.AudioScene], t: float) -> list[m.AudioScene]:
    """The scene sounding at `t` (the last one at or before it) and every later one."""
    later = next((k for k, s in enumerate(scenes) if s.t > t), len(scenes))
    return scenes[max(0, later - 1) :]


def play_scenes(
    renderer: Renderer,
    scenes: Sequence[m.AudioScene],
    end: float,
    write: Callable[[np.ndarray], None],
    listener_at: Callable[[float], ListenerPose] | None = None,
    progress: Progress | None = None,
    start: float | None = None,
) -> None:
    """Render from `start` (default: the first scene's time) to `end` [s], each scene taken
    at its own time and the ears placed by `listener_at(t)` every block; blocks go to
    `write`. `progress` hears the fraction rendered and the session time reached: 0.0 first,
    then every `PROGRESS_BLOCKS` blocks, 1.0 last."""
    begin = renderer.t = scenes[0].t if start is None else start
    next_scene = 0
    if progress is not None:
        progress(0.0, begin)
    while renderer.t < end:
        while next_scene < len(scenes) and scenes[next_scene].t <= renderer.t:
            renderer.hear(scenes[next_scene].emitters, scenes[next_scene].t)
            next_scene += 1
        if listener_at is not None:
            renderer.place(listener_at(renderer.t))
        write(renderer.render_block())
        if progress is not None and renderer.blocks % PROGRESS_BLOCKS == 0:
            progress(min(1.0, (renderer.t - begin) / (end - begin)), min(renderer.t, end))
    if progress is not None:
        progress(1.0, end)


def _check(recorded: RecordedAudio, listener: str, path: str | Path) -> PoseTrack:
    if not recorded.scenes:
        have = ", ".join(sorted(recorded.listeners)) or "none"
        raise NothingToRender(f"{path} has no audio/{listener} scenes (listeners with audio: "
                              f"{have})")  # fmt: skip
    if not recorded.poses:
        raise NothingToRender(f"{path} has no ego/{listener}/pose: the listener's ears need "
                              "its pose")  # fmt: skip
    return PoseTrack(recorded.poses)
