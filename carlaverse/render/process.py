"""The view of a live node, in a process of its own at display rate.

    view = ViewProcess(ViewSpec(node_settings, fabric, render_config, own=block)).start()
    ...                                   # the node runs; its 1 kHz loop is never touched
    summary = view.close()                # frames, each frame's parts, motion-to-photon

The render process never shares a lock or a thread with the node: it reads the node's own
pose from the node's shared-memory block (a seqlock: the writer never waits) and opens its
own fabric session for everyone else (`live.LiveWorld`). It ends when told to, when its
parent process is gone, or when its window is closed. In offscreen mode it can write a PNG
every `out_every_s` to `out_dir`, so a headless run can be looked at and tested.

What a frame costs is what a participant pays for it: `fps` and `frame_ms` count the whole
frame, measured in three parts: drawing (the world's state read, the scene updated and
rendered), read-back (the image copied from the GPU to RAM: every frame offscreen, where the
read-back image is the view's only output, else only for a PNG or a headset's eyes) and
writing (a PNG and its line in `frames.jsonl`, on frames that write one).

Motion-to-photon: the node's loop stamps each state it writes with the host's monotonic clock
(`written_ns`, CLOCK_MONOTONIC is one clock for every process of the host). A frame drawn
from a state not drawn before counts from that stamp to the end of its read-back (offscreen),
or to the end of its render (a window: Panda3D swaps the buffers when the next frame starts,
so there the figure is a lower bound by up to a frame). Writing a PNG comes after and is
reported apart (`write_ms`).

Cameras: `own` rides in the node's actor at the rig's head position (an observer without an
actor gets the free camera), `free` looks over the map, any other value is an actor id the
camera chases from behind.
"""

from __future__ import annotations

import json
import logging
import multiprocessing as mp
import os
import queue
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from carlaverse.render.rig import RenderConfig
from carlaverse.shm_layouts import OwnPoseBlock
from carlaverse.support.stats import percentile
from carlaverse.transport.node_client import NodeSettings
from carlaverse.transport.session import FabricSettings

if TYPE_CHECKING:
    import numpy as np

log = logging.getLogger(__name__)

OWN, FREE = "own", "free"
FRAME_TIMES_KEPT = 216_000  # an hour at 60 frames/s
FRAMES_LOG = "frames.jsonl"  # beside the PNGs: per written frame, its state's stamp and photon
CLOSE_TIMEOUT_S = 10.0  # [s] for the render process to finish its frame and report


@dataclass(frozen=True)
class ViewSpec:
    """Everything the render process needs; picklable (it crosses a spawn boundary)."""

    node: NodeSettings
    fabric: FabricSettings
    render: RenderConfig
    own: OwnPoseBlock | None = None
    camera: str = OWN  # own | free | an actor id to chase
    out_dir: str | None = None  # write a PNG here every out_every_s (offscreen testing)
    out_every_s: float = 0.5  # [s]
    map_timeout_s: float = 30.0  # [s] how long to wait for the authority's map


def _times() -> deque[float]:
    return deque(maxlen=FRAME_TIMES_KEPT)


@dataclass
class ViewSummary:
    frames: int = 0
    written: int = 0
    fps: float = 0.0  # frames per second, first frame's start to last frame's end
    frame_ms_p50: float = float("nan")  # the whole frame: draw + read-back + write
    frame_ms_p99: float = float("nan")
    frame_ms_mean: float = float("nan")
    draw_ms_p50: float = float("nan")  # world state read, scene updated, rendered
    draw_ms_p99: float = float("nan")
    readback_ms_p50: float = float("nan")  # GPU image to RAM, frames that read back
    readback_ms_p99: float = float("nan")
    write_ms_p50: float = float("nan")  # PNG and its log line, frames that wrote one
    write_ms_p99: float = float("nan")
    readback_frames: int = 0
    photon_at: str = ""  # "read-back" (offscreen) or "render" (a window): where latency ends
    motion_to_photon_ms_p50: float = float("nan")
    motion_to_photon_ms_p99: float = float("nan")
    motion_to_photon_frames: int = 0  # frames drawn from a stamped state not drawn before
    gl_renderer: str = ""
    map_lanes: int = 0
    own_pose_torn_reads: int = 0  # own-pose reads that met the loop mid-write (drawn from the last)
    eye_frames: int = 0  # frames whose eyes went to the node's headset (`eye_images`)
    eye_frames_resampled: bool = False  # the rig drew another size than the headset shows
    pid: int = 0  # of the render process (a test can check it is gone)
    error: str = ""
    # the newest FRAME_TIMES_KEPT frames' parts [s]: the percentiles above cover the last hour
    frame_times_s: deque[float] = field(default_factory=_times, repr=False)
    draw_times_s: deque[float] = field(default_factory=_times, repr=False)
    readback_times_s: deque[float] = field(default_factory=_times, repr=False)
    write_times_s: deque[float] = field(default_factory=_times, repr=False)
    motion_to_photon_s: deque[float] = field(default_factory=_times, repr=False)

    RAW = ("frame_times_s", "draw_times_s", "readback_times_s", "write_times_s",
           "motion_to_photon_s")  # fmt: skip

    def report(self) -> dict[str, Any]:
        """The summary without the raw times (for a node's exit report)."""
        return {k: v for k, v in self.__dict__.items() if k not in self.RAW}

    def settle(self) -> None:
        """Percentiles from the raw times, which are then dropped (the node reads these)."""
        for prefix, raw in (("frame_ms", self.frame_times_s), ("draw_ms", self.draw_times_s),
                            ("readback_ms", self.readback_times_s),
                            ("write_ms", self.write_times_s),
                            ("motion_to_photon_ms", self.motion_to_photon_s)):  # fmt: skip
            times = list(raw)
            if times and prefix == "frame_ms":
                self.frame_ms_mean = round(sum(times) / len(times) * 1e3, 2)
            if times:
                setattr(self, f"{prefix}_p50", round(percentile(times, 0.5) * 1e3, 2))
                setattr(self, f"{prefix}_p99", round(percentile(times, 0.99) * 1e3, 2))
            raw.clear()


class ViewProcess:
    """The parent's handle on the render process."""

    def __init__(self, spec: ViewSpec) -> None:
        self.spec = spec
        ctx = mp.get_context("spawn")  # a fresh interpreter: Panda3D never enters the node
        self._stop = ctx.Event()
        self._results: Any = ctx.Queue()
        self.process = ctx.Process(
            target=run_view, args=(spec, self._stop, self._results),
            name=f"{spec.node.node_id}-view", daemon=True,
        )  # fmt: skip

    def start(self) -> ViewProcess:
        self.process.start()
        return self

    def alive(self) -> bool:
        return self.process.is_alive()

    def close(self, timeout_s: float = CLOSE_TIMEOUT_S) -> ViewSummary:
        """Stop the render process and return what it reports."""
        self._stop.set()
        try:
            summary: ViewSummary = self._results.get(timeout=timeout_s)
        except queue.Empty:
            summary = ViewSummary(error="the render process did not report")
        self.process.join(timeout=timeout_s)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        return summary


def run_view(spec: ViewSpec, stop: Any, results: Any) -> None:
    """Entry point of the render process."""
    summary = ViewSummary(pid=os.getpid())
    try:
        _run(spec, stop, summary)
    except Exception as exc:  # the node must hear why its view is gone; it keeps running
        log.exception("the view of %s failed", spec.node.node_id)
        summary.error = f"{type(exc).__name__}: {exc}"
    finally:
        summary.settle()
        results.put(summary)


def _run(spec: ViewSpec, stop: Any, summary: ViewSummary) -> None:
    from carlaverse.render.live import LiveWorld
    from carlaverse.render.renderer import Renderer
    from carlaverse.transport.session import open_session

    session = open_session(spec.fabric)
    world = LiveWorld(session, spec.node, spec.own).start()
    try:
        road_map = _wait_for_map(world, spec.map_timeout_s, stop)
        summary.map_lanes = len(road_map.lanes) if road_map else 0
        title = f"carlaverse: {spec.node.node_id}"
        with Renderer(spec.render, road_map, title=title) as renderer:
            summary.gl_renderer = renderer.gl_renderer
            _loop(spec, stop, world, renderer, summary)
    finally:
        summary.own_pose_torn_reads = world.own.torn_reads if world.own is not None else 0
        world.close()
        session.close()


def _wait_for_map(world: Any, timeout_s: float, stop: Any) -> Any:
    """The authority's map; None when the session has none, or when it does not come (the
    view then draws the actors over plain ground, and says why in the log)."""
    from carlaverse.render.live import WorldMissing

    try:
        return world.wait_for_map(time.monotonic() + timeout_s, stop)
    except WorldMissing as exc:
        log.warning("the view of %s draws no map: %s", world.node_id, exc)
        return None


def _loop(spec: ViewSpec, stop: Any, world: Any, renderer: Any, summary: ViewSummary) -> None:
    period = 1.0 / spec.render.max_fps
    dump = FrameDump(spec.out_dir, spec.out_every_s)
    headset = _eye_writer(spec)
    offscreen = spec.render.output == "offscreen"
    summary.photon_at = "read-back" if offscreen else "render"
    drawn_ns = 0  # the stamp of the last state drawn: a state drawn again is no new motion
    parent = mp.parent_process()
    next_t = time.monotonic()
    first = last = 0.0
    while not stop.is_set() and (parent is None or parent.is_alive()):
        started = time.perf_counter()
        frame = world.frame()
        state_ns = world.own.written_ns if world.own is not None else 0
        eyes = world.own.eyes if world.own is not None else None
        if eyes is not None:  # a walker's headset reports its eyes: draw with those
            renderer.rig.set_eye_frusta(eyes)
        dash = world.own.dash if world.own is not None else None  # for the HUD, riding
        renderer.draw(frame, **aim(spec.camera, frame, world.node_id), dash=dash)
        if renderer.graphics.closed():
            break  # the user closed the window: the view ends, the node goes on
        drawn = time.perf_counter()
        images = renderer.images() if offscreen or dump.due() or headset is not None else None
        photon_ns = time.monotonic_ns()
        read = time.perf_counter()
        summary.written += dump.offer(images, state_ns, photon_ns)
        if headset is not None and len(renderer.layout.cameras) == 2:
            summary.eye_frames += headset.offer(renderer.camera_images())
        ended = time.perf_counter()
        _account(summary, (started, drawn, read, ended), images is not None, dump.wrote)
        if state_ns and state_ns != drawn_ns:
            summary.motion_to_photon_s.append((photon_ns - state_ns) * 1e-9)
            summary.motion_to_photon_frames += 1
            drawn_ns = state_ns
        first, last = first or started, ended
        next_t += period
        delay = next_t - time.monotonic()
        if delay < -period:
            next_t, delay = time.monotonic(), 0.0  # behind: drop frames, never burst
        stop.wait(max(0.0, delay))
    if summary.frames > 1:
        summary.fps = round(summary.frames / (last - first), 1)
    if headset is not None:
        summary.eye_frames_resampled = headset.resampled
        headset.close()


def _account(summary: ViewSummary, marks: tuple[float, float, float, float], read_back: bool,
             wrote: bool) -> None:  # fmt: skip
    """One frame's parts from its marks: start, drawn, read back, written."""
    started, drawn, read, ended = marks
    summary.frames += 1
    summary.frame_times_s.append(ended - started)
    summary.draw_times_s.append(drawn - started)
    if read_back:
        summary.readback_times_s.append(read - drawn)
        summary.readback_frames += 1
    if wrote:
        summary.write_times_s.append(ended - read)


def _eye_writer(spec: ViewSpec) -> Any:
    """Where the eyes go when the node's headset shows them (`OwnPoseBlock.eye_images`)."""
    if spec.own is None or not spec.own.eye_images:
        return None
    from carlaverse.hal.xr.eye_images import EyeImageWriter

    return EyeImageWriter(spec.own.eye_images)


def aim(camera: str, frame: Any, own_id: str) -> dict[str, Any]:
    """The `Renderer.draw` arguments that point the rig for `camera`."""
    from carlaverse.render.cameras import chase_eye

    if camera == OWN:
        return {"follow": own_id} if frame.actor(own_id) is not None else {}
    if camera == FREE:
        return {}
    target = frame.actor(camera)
    return {"eye": chase_eye(target)} if target is not None else {}


class FrameDump:
    """Writes the view's first output as numbered PNGs, at most one per `every_s`, and a line
    per PNG in `frames.jsonl`: the state's write stamp and the photon's (monotonic ns)."""

    def __init__(self, out_dir: str | None, every_s: float) -> None:
        self.dir = Path(out_dir) if out_dir else None
        if self.dir is not None:
            self.dir.mkdir(parents=True, exist_ok=True)
        self.every_s = every_s
        self.count = 0
        self.wrote = False  # whether the last offer wrote
        self._next = time.monotonic()

    def due(self) -> bool:
        return self.dir is not None and time.monotonic() >= self._next

    def offer(self, images: list[np.ndarray] | None, state_ns: int, photon_ns: int) -> int:
        """Write the frame if one is due; returns how many were written (0 or 1)."""
        self.wrote = False
        if self.dir is None or images is None or not self.due():
            return 0
        from carlaverse.render.video import save_png

        self._next = time.monotonic() + self.every_s
        name = f"frame-{self.count:05d}.png"
        partial = self.dir / f".{name}"  # renamed when complete: readers never see half a file
        save_png(partial, images[0])
        partial.replace(self.dir / name)
        line = {"png": name, "state_ns": state_ns, "photon_ns": photon_ns}
        with (self.dir / FRAMES_LOG).open("a") as log_file:
            log_file.write(json.dumps(line) + "\n")
        self.count += 1
        self.wrote = True
        return 1
