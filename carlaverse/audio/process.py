"""A live node's audio, in a process of its own: `carlaverse join KIND --audio CONFIG`.

    audio = AudioProcess(AudioSpec(node_id, config, block)).start()
    client = NodeClient(..., audio_scenes=audio.scene)   # the scenes the node's client accepts
    ...                                     # the node runs; its control loop is never touched
    summary = audio.close()                 # blocks played, underruns, update latency

The node's client hears `audio/<node id>` like every other key, through its guarded inbound
(`transport.inbound`: decoded, from the joined authority only, a bad or forged scene counted
and dropped), and hands each scene over here (`scene`, a queue put that never waits). The
process reads the node's ears from its shared state (`ears.Ears`) or, for a kind without
one, from the poses the node publishes (`pose`), renders block after block and queues them
for the output device (`output`), which paces it. It opens no Zenoh session. It ends when
told, or when its parent is gone.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import queue
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from carlaverse import messages as m
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.ears import BlockSpec, Ears
from carlaverse.audio.scene import LOCAL
from carlaverse.support.stats import percentile

log = logging.getLogger(__name__)

CLOSE_TIMEOUT_S = 10.0  # [s] for the audio process to stop and report
START_TIMEOUT_S = 60.0  # [s] for it to load its HRTF set and open its output (a slow host)
READY = "ready"
PENDING_SCENES = 8  # scenes waiting for the next block; more means the renderer stalled
PUT_TIMEOUT_S = 0.25  # [s] a full queue this long: look at the stop flag again
HANDOVER_LIMIT = 64  # scenes and poses on their way from the node; more are dropped, counted


@dataclass(frozen=True)
class AudioSpec:
    """Everything the audio process needs; picklable (it crosses a spawn boundary)."""

    node_id: str
    config: AudioConfig
    block: BlockSpec | None = None  # the node's shared state to read the ears from, if any


@dataclass
class AudioSummary:
    layout: str = ""
    device: str = ""
    blocks: int = 0  # played by the device
    underruns: int = 0  # blocks the device needed that were not ready
    playing_s: float = 0.0  # [s] wall time since the device began to play
    scenes: int = 0
    late_scenes: int = 0  # replaced by a newer one before a block took them
    handover_dropped: int = 0  # scenes and poses the node could not hand over (queue full)
    emitters_max: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    latency_ms_p50: float = float("nan")  # emitter update → the block carrying it plays
    latency_ms_p99: float = float("nan")
    cpu_per_audio_s: float = float("nan")  # CPU seconds per second of audio rendered
    priority: str = ""  # how the audio process is scheduled
    pid: int = 0
    error: str = ""


class SceneInbox:
    """What the node handed over, for the render loop: scenes with their arrival time
    (CLOCK_MONOTONIC, one clock for both processes) and the listener's newest pose."""

    def __init__(self, incoming: Any = None) -> None:
        self._incoming = incoming  # the queue from the node's process (None: filled directly)
        self.scenes: deque[tuple[m.AudioScene, float]] = deque(maxlen=PENDING_SCENES)
        self.received = 0
        self.pose: m.Pose | None = None

    def take(self) -> list[tuple[m.AudioScene, float]]:
        self._drain()
        taken = []
        while self.scenes:
            taken.append(self.scenes.popleft())
        return taken

    def _drain(self) -> None:
        while self._incoming is not None:
            try:
                item = self._incoming.get_nowait()
            except queue.Empty:
                return
            if item[0] == "scene":
                self.received += 1
                self.scenes.append(item[1:])
            else:
                self.pose = item[1]


class AudioProcess:
    """The parent's handle on the audio process."""

    def __init__(self, spec: AudioSpec) -> None:
        ctx = mp.get_context("spawn")  # a fresh interpreter: PortAudio never enters the node
        self._stop = ctx.Event()
        self._results: Any = ctx.Queue()
        self._incoming: Any = ctx.Queue(maxsize=HANDOVER_LIMIT)
        self._wants_poses = spec.block is None  # no shared state: the ears follow the poses
        self.handover_dropped = 0
        args = (spec, self._stop, self._results, self._incoming)
        self.process = ctx.Process(target=run_audio, args=args, name=f"{spec.node_id}-audio",
                                   daemon=True)  # fmt: skip

    def scene(self, scene: m.AudioScene) -> None:
        """A scene the node's client accepted (called on a Zenoh thread: never waits)."""
        self._hand(("scene", scene, time.monotonic()))

    def pose(self, pose: m.Pose) -> None:
        """A pose the node published: where its ears are, for a kind without shared state."""
        if self._wants_poses:
            self._hand(("pose", pose))

    def _hand(self, item: tuple[Any, ...]) -> None:
        try:
            self._incoming.put_nowait(item)  # pickled and sent by the queue's own thread
        except queue.Full:  # the audio process fell behind or is gone
            self.handover_dropped += 1

    def start(self, timeout_s: float = START_TIMEOUT_S) -> AudioProcess:
        """Start it and wait until its output is open; OutputError (its one line) if not."""
        from carlaverse.audio.output import OutputError

        self.process.start()
        try:
            first = self._results.get(timeout=timeout_s)
        except queue.Empty:
            self.close(timeout_s=1.0)
            raise OutputError(f"the audio process did not start in {timeout_s:g} s") from None
        if isinstance(first, AudioSummary):  # it ended before it was ready: the reason
            self.process.join(timeout=CLOSE_TIMEOUT_S)
            raise OutputError(first.error)
        return self

    def close(self, timeout_s: float = CLOSE_TIMEOUT_S) -> AudioSummary:
        """Stop the audio process and return what it reports."""
        self._stop.set()
        try:
            summary: AudioSummary = self._results.get(timeout=timeout_s)
        except queue.Empty:
            summary = AudioSummary(error="the audio process did not report")
        summary.handover_dropped = self.handover_dropped
        self.process.join(timeout=timeout_s)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        return summary


def run_audio(spec: AudioSpec, stop: Any, results: Any, incoming: Any) -> None:
    """Entry point of the audio process."""
    summary = AudioSummary(layout=spec.config.layout, pid=os.getpid())
    try:
        _run(spec, stop, results, incoming, summary)
    except Exception as exc:  # the node must hear why its audio is gone; it keeps running
        log.warning("the audio of %s failed: %s", spec.node_id, exc)
        summary.error = str(exc) if type(exc).__name__ == "OutputError" else (
            f"{type(exc).__name__}: {exc}")  # fmt: skip
    finally:
        results.put(summary)


def _run(spec: AudioSpec, stop: Any, results: Any, incoming: Any, summary: AudioSummary) -> None:
    from carlaverse.audio.output import open_output
    from carlaverse.audio.renderer import build_renderer, layout_channels
    from carlaverse.realtime import raise_priority

    # Before any thread starts: they inherit it (the device's, Zenoh's own run at theirs).
    summary.priority = raise_priority(spec.config.output.realtime_priority)
    output = open_output(spec.config, layout_channels(spec.config.layout))  # fails fast
    renderer = build_renderer(spec.config)
    summary.device = output.device
    inbox, ears = SceneInbox(incoming), Ears(spec.config.listener, spec.block)
    results.put(READY)
    cpu_start = time.process_time()
    try:
        _loop(spec, stop, renderer, output, inbox, ears, summary)
    finally:
        _report(summary, renderer, output, inbox, time.process_time() - cpu_start)
        output.close()
        ears.close()


def _loop(spec: AudioSpec, stop: Any, renderer: Any, output: Any, inbox: SceneInbox,
          ears: Ears, summary: AudioSummary) -> None:  # fmt: skip
    parent = mp.parent_process()
    started = False
    stamp: float | None = None
    while not stop.is_set() and (parent is None or parent.is_alive()):
        for scene, arrived in _newest(inbox, summary):
            renderer.hear(scene.emitters, renderer.t)
            summary.emitters_max = max(summary.emitters_max, len(scene.emitters))
            stamp = arrived
        ears.pose = inbox.pose
        listener = ears.listener(renderer.t)
        if listener is not None:
            renderer.place(listener)
        renderer.hear(ears.own_emitters(renderer.t), renderer.t, LOCAL)
        block = renderer.render_block()
        while not output.queue.put(block, stamp, PUT_TIMEOUT_S):
            if stop.is_set():
                return
        if not started and output.queue.full():
            output.start()  # prefilled: the device may begin
            started = True


def _newest(inbox: SceneInbox, summary: AudioSummary) -> list[tuple[m.AudioScene, float]]:
    """Only the newest pending scene matters: each replaces the whole emitter list."""
    taken = inbox.take()
    summary.late_scenes += max(0, len(taken) - 1)
    return taken[-1:]


def _report(summary: AudioSummary, renderer: Any, output: Any, inbox: SceneInbox,
            cpu_s: float) -> None:  # fmt: skip
    summary.blocks, summary.underruns = output.played, output.underruns
    summary.playing_s = round(output.playing_s(), 3)
    summary.scenes = inbox.received
    summary.dropped = dict(renderer.slots.dropped)
    rendered_s = renderer.blocks * renderer.block / renderer.rate
    if rendered_s > 0:
        summary.cpu_per_audio_s = round(cpu_s / rendered_s, 3)
    if latencies := list(output.latencies_s):
        summary.latency_ms_p50 = round(percentile(latencies, 0.5) * 1e3, 1)
        summary.latency_ms_p99 = round(percentile(latencies, 0.99) * 1e3, 1)


def audio_report(summary: AudioSummary) -> dict[str, Any]:
    """The summary as a node's exit report carries it."""
    return dict(summary.__dict__)
