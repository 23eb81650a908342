"""The view of a live node, in a process of its own at display rate.

    view = ViewProcess(ViewSpec(node_settings, fabric, render_config, own=block)).start()
    ...                                   # the node runs; its 1 kHz loop is never touched
    summary = view.close()                # frames drawn, frame times, frames written

The render process never shares a lock or a thread with the node: it reads the node's own
pose from the node's shared-memory block (a seqlock: the writer never waits) and opens its
own fabric session for everyone else (`live.LiveWorld`). It ends when told to, when its
parent process is gone, or when its window is closed. In offscreen mode it can write a PNG
every `out_every_s` to `out_dir`, so a headless run can be looked at and tested.

Cameras: `own` rides in the node's actor at the rig's head position (an observer without an
actor gets the free camera), `free` looks over the map, any other value is an actor id the
camera chases from behind.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import queue
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from carlaverse.render.live import OwnPoseBlock
from carlaverse.render.rig import RenderConfig
from carlaverse.support.stats import percentile
from carlaverse.transport.node_client import NodeSettings
from carlaverse.transport.session import FabricSettings

log = logging.getLogger(__name__)

OWN, FREE = "own", "free"
FRAME_TIMES_KEPT = 216_000  # an hour at 60 frames/s
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


@dataclass
class ViewSummary:
    frames: int = 0
    written: int = 0
    fps: float = 0.0  # frames per second while drawing (after the map arrived)
    frame_ms_p50: float = float("nan")
    frame_ms_p99: float = float("nan")
    gl_renderer: str = ""
    map_lanes: int = 0
    own_pose_torn_reads: int = 0  # own-pose reads that met the loop mid-write (drawn from the last)
    eye_frames: int = 0  # frames whose eyes went to the node's headset (`eye_images`)
    eye_frames_resampled: bool = False  # the rig drew another size than the headset shows
    pid: int = 0  # of the render process (a test can check it is gone)
    error: str = ""
    # the newest FRAME_TIMES_KEPT frames' times: the percentiles above cover the last hour
    frame_times_s: deque[float] = field(
        default_factory=lambda: deque(maxlen=FRAME_TIMES_KEPT), repr=False
    )

    def report(self) -> dict[str, Any]:
        """The summary without the raw frame times (for a node's exit report)."""
        return {k: v for k, v in self.__dict__.items() if k != "frame_times_s"}


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
        times = list(summary.frame_times_s)
        if times:
            summary.frame_ms_p50 = round(percentile(times, 0.5) * 1e3, 2)
            summary.frame_ms_p99 = round(percentile(times, 0.99) * 1e3, 2)
        summary.frame_times_s.clear()  # the node reads the percentiles, not the raw times
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
    parent = mp.parent_process()
    first = next_t = time.monotonic()
    while not stop.is_set() and (parent is None or parent.is_alive()):
        started = time.perf_counter()
        frame = world.frame()
        eyes = world.own.eyes if world.own is not None else None
        if eyes is not None:  # a walker's headset reports its eyes: draw with those
            renderer.rig.set_eye_frusta(eyes)
        dash = world.own.dash if world.own is not None else None  # for the HUD, riding
        renderer.draw(frame, **aim(spec.camera, frame, world.node_id), dash=dash)
        if renderer.graphics.closed():
            break  # the user closed the window: the view ends, the node goes on
        summary.frames += 1
        summary.frame_times_s.append(time.perf_counter() - started)
        summary.written += dump.offer(renderer)
        if headset is not None and len(renderer.layout.cameras) == 2:
            summary.eye_frames += headset.offer(renderer.camera_images())
        next_t += period
        delay = next_t - time.monotonic()
        if delay < -period:
            next_t, delay = time.monotonic(), 0.0  # behind: drop frames, never burst
        stop.wait(max(0.0, delay))
    if summary.frames > 1:
        summary.fps = round(summary.frames / (time.monotonic() - first), 1)
    if headset is not None:
        summary.eye_frames_resampled = headset.resampled
        headset.close()


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
    """Writes the view's first output as numbered PNGs, at most one per `every_s`."""

    def __init__(self, out_dir: str | None, every_s: float) -> None:
        self.dir = Path(out_dir) if out_dir else None
        if self.dir is not None:
            self.dir.mkdir(parents=True, exist_ok=True)
        self.every_s = every_s
        self.count = 0
        self._next = time.monotonic()

    def offer(self, renderer: Any) -> int:
        """Write the current frame if one is due; returns how many were written (0 or 1)."""
        if self.dir is None or time.monotonic() < self._next:
            return 0
        from carlaverse.render.video import save_png

        self._next = time.monotonic() + self.every_s
        name = f"frame-{self.count:05d}.png"
        partial = self.dir / f".{name}"  # renamed when complete: readers never see half a file
        save_png(partial, renderer.images()[0])
        partial.replace(self.dir / name)
        self.count += 1
        return 1
