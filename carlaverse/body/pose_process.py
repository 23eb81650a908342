"""The Pose Process: camera → MediaPipe landmarks → joint angles, in a process of its own.

Vision inference takes tens of milliseconds; run in the node's process it would stall the
node's loop and the view. The child opens the camera and the landmarker, and for each frame
sends (capture time [s, monotonic], joint names, angle bytes) through a pipe; the node's
`poll()` drains the pipe without waiting and keeps the newest. The child says "ready" once its
camera and model are open, or sends its one-line error and ends — `start()` raises that line
in the node, so an absent camera or model fails at start-up, not silently later.

CLOCK_MONOTONIC is one clock for every process on a host, so the capture time the child
measures is put on the source's clock (monotonic unless given another) by the age of the
frame when it is polled.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from carlaverse import messages as m
from carlaverse.body.errors import BodyPoseError
from carlaverse.body.model import require
from carlaverse.body.skeleton import BodyConfig, Clock, angles_bytes, visible_joints
from carlaverse.hal.errors import HalError

log = logging.getLogger(__name__)

CLOSE_TIMEOUT_S = 5.0  # [s] for the child to finish its frame and exit


@dataclass(frozen=True)
class PoseResult:
    """One frame's outcome, as the child sends it."""

    capture_t: float  # [s] monotonic, when the camera delivered the frame
    joints: list[str]  # empty: no person in the frame
    angles: bytes  # float32 (roll, pitch, yaw) per joint
    infer_s: float  # [s] landmarker + angles time


class CameraBodySource:
    """The node's handle on the pose process; `poll()` never waits."""

    def __init__(self, config: BodyConfig, clock: Clock = time.monotonic) -> None:
        self.config = config
        self.clock = clock
        ctx = mp.get_context("spawn")  # a fresh interpreter: no Zenoh threads forked
        self._conn, child = ctx.Pipe(duplex=False)
        self._stop = ctx.Event()
        args = (msgspec.json.encode(config), child, self._stop)
        self.process = ctx.Process(target=run_pose, name="pose", daemon=True, args=args)
        self._child_conn = child
        self._seq = 0
        self.frames = 0  # results received, with or without a person
        self.stopped = ""  # why the pose process ended, once it has
        self.newest: PoseResult | None = None

    def start(self) -> CameraBodySource:
        """Start the child and wait until its camera and model are open."""
        if self.config.camera.backend != "sim":  # a missing model is said before spawning
            require(Path(self.config.model) if self.config.model else None)
        self.process.start()
        self._child_conn.close()
        if not self._conn.poll(self.config.start_timeout_s):
            self.close()
            waited = f"{self.config.start_timeout_s:g} s (body.start_timeout_s)"
            raise BodyPoseError(f"the pose process was not ready within {waited}")
        status = self._receive()
        if status != "ready":
            self.close()
            raise BodyPoseError(status if isinstance(status, str) else "pose process failed")
        return self

    def _receive(self) -> Any:
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            return "the pose process ended without a word (see its log)"

    def poll(self) -> m.Skeleton | None:
        """A Skeleton of the newest frame with a person since the last poll, or None."""
        found = None
        while not self.stopped and self._conn.poll():
            result = self._receive()
            if not isinstance(result, PoseResult):
                self.stopped = str(result)  # the child's last word, and it ends
                log.warning("body pose stopped: %s", self.stopped)
                break
            self.frames += 1
            if result.joints:
                found = self.newest = result
        if found is None:
            return None
        self._seq += 1
        age_s = time.monotonic() - found.capture_t
        return m.Skeleton(self._seq, self.clock() - age_s, found.joints, found.angles)

    def alive(self) -> bool:
        return self.process.is_alive()

    def close(self) -> None:
        self._stop.set()
        self.process.join(CLOSE_TIMEOUT_S)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self._conn.close()


def run_pose(config_json: bytes, conn: Any, stop: Any) -> None:
    """Entry point of the pose process."""
    config = msgspec.json.decode(config_json, type=BodyConfig)
    try:
        pin_cpu(config.cpu)
        camera, landmarker = _open(config)
    except (BodyPoseError, HalError, ValueError) as exc:  # said in one line by the parent
        conn.send(str(exc))
        conn.close()
        return
    conn.send("ready")
    try:
        _loop(config, camera, landmarker, conn, stop)
    except (BrokenPipeError, EOFError):
        pass  # the node went away: nothing left to tell
    except HalError as exc:  # the camera failed mid-run (unplugged, end of a video file)
        conn.send(str(exc))
    finally:
        camera.close()
        if landmarker is not None:
            landmarker.close()
        conn.close()


def pin_cpu(cpu: str | int) -> int | None:
    """Keep this process on one CPU (`BodyConfig.cpu`); which one, or None for "any"."""
    if cpu == "any" or not hasattr(os, "sched_setaffinity"):
        return None
    allowed = sorted(os.sched_getaffinity(0))
    chosen = allowed[-1] if cpu == "last" else cpu
    if chosen not in allowed:
        raise BodyPoseError(f"body.options.cpu {cpu}: the pose process may run on CPUs {allowed}")
    os.sched_setaffinity(0, {chosen})
    return int(chosen)


def _open(config: BodyConfig) -> tuple[Any, Any]:
    from carlaverse.hal.camera import CameraConfig, registry
    from carlaverse.hal.device import open_device

    camera = open_device(registry(), config.camera, CameraConfig, source="body.camera")
    if config.camera.backend == "sim":
        return camera, None  # the sim camera gives landmarks itself
    from carlaverse.body.landmarker import PoseLandmarker

    try:
        return camera, PoseLandmarker(Path(config.model) if config.model else None)
    except BaseException:
        camera.close()
        raise


def _loop(config: BodyConfig, camera: Any, landmarker: Any, conn: Any, stop: Any) -> None:
    period = 1.0 / config.rate_hz
    parent = mp.parent_process()
    next_t = time.monotonic()
    while not stop.is_set() and (parent is None or parent.is_alive()):
        conn.send(estimate(camera.read(), landmarker, config.min_visibility))
        next_t += period
        delay = next_t - time.monotonic()
        if delay < -period:
            next_t, delay = time.monotonic(), 0.0  # behind: skip frames, never burst
        stop.wait(max(0.0, delay))


def estimate(frame: Any, landmarker: Any, min_visibility: float) -> PoseResult:
    """Joint angles of the person in one camera frame (none when nobody is seen)."""
    from carlaverse.body.kinematics import joint_angles

    started = time.perf_counter()
    landmarks, visibility = frame.landmarks, frame.visibility
    if landmarker is not None:
        found = landmarker.detect(frame.image, frame.t)
        landmarks, visibility = (found.world, found.visibility) if found else (None, None)
    if landmarks is None:
        return PoseResult(frame.t, [], b"", time.perf_counter() - started)
    angles = visible_joints(joint_angles(landmarks), visibility, min_visibility)
    names, raw = angles_bytes(angles)
    return PoseResult(frame.t, names, raw, time.perf_counter() - started)
