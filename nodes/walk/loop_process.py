"""The walk node's loop process (the paper's Control Process): headset, controllers and
keyboard/gamepad → `WalkControl` → shared state, at `loop.rate_hz` (90 Hz) in a process of its
own, never touching the network. Timing and priority come from `carlaverse.realtime`.

Events from the fabric process arrive on a queue: the walkable lanes of the map (an (n, 5)
array, see `walkable.Walkable.to_arrays`) and impulses (counted: a pedestrian is not thrown).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from carlaverse_nodes.loop_events import drain
from carlaverse_nodes.walk.config import WalkNodeConfig
from carlaverse_nodes.walk.shared_state import CONTROL, STATE
from carlaverse_nodes.walk.walk_control import WalkControl, WalkOutput
from carlaverse_nodes.walk.walkable import Walkable

from carlaverse.hal import open_input, open_xr
from carlaverse.hal.xr.eye_images import EyeImageBlock
from carlaverse.messages import Impulse
from carlaverse.procs import ParentWatch
from carlaverse.realtime import Pacer, raise_priority
from carlaverse.shm import SharedBlock, new_record
from carlaverse.shm_layouts import EDGES, EYES

log = logging.getLogger(__name__)

CONTROL_POLL_S = 0.05  # [s] re-read the clock offset and the spawn
EVENT_POLL_S = 0.02  # [s] look at the event queue


@dataclass(frozen=True)
class WalkLoopSpec:
    config: WalkNodeConfig
    state_block: str
    control_block: str
    eye_images: str = ""  # block name for the view's rendered eyes, when the headset shows them


def run_walk_loop(spec: WalkLoopSpec, events: Any, results: Any, stop: Any) -> None:
    """Entry point of the loop process."""
    raise_priority(spec.config.loop.realtime_priority)
    state = SharedBlock(spec.state_block, STATE)
    control = SharedBlock(spec.control_block, CONTROL)
    runner: WalkRunner | None = None
    try:
        runner = WalkRunner(spec, state, control, events)
        runner.run(stop)
    except Exception as exc:  # e.g. a device that cannot open: the node reports it in one line
        log.debug("walk loop failed", exc_info=True)
        results.put({"error": f"{type(exc).__name__}: {exc}"})
    finally:
        if runner is not None:
            results.put(runner.summary())
            runner.close()
        state.close()
        control.close()


class WalkRunner:
    def __init__(self, spec: WalkLoopSpec, state: SharedBlock, control: SharedBlock,
                 events: Any) -> None:  # fmt: skip
        config = spec.config
        self.config, self.state, self.control, self.events = config, state, control, events
        self.offset = float(control.read()["clock_offset"])
        self.headset = open_xr(config.xr, source="xr")
        try:
            self.device = open_input(config.input, source="input") if config.input else None
        except Exception:
            self.headset.close()
            raise
        self.eyes = self._eye_block(spec.eye_images)
        self.walk = WalkControl(config, self.headset, self.device)
        self.record = new_record(STATE)
        self.pacer = Pacer(config.loop.rate_hz)
        self.spawn_seq = 0
        self.ticks = self.impulses = self.eye_frames = 0
        self.distance_m = 0.0

    def _eye_block(self, name: str) -> EyeImageBlock | None:
        """The block the view writes the eyes into, at the headset's display size."""
        size = self.headset.display_size()
        if not name or size is None:
            return None
        try:
            return EyeImageBlock(name, *size)
        except Exception:
            self.headset.close()
            if self.device is not None:
                self.device.close()
            raise

    def run(self, stop: Any) -> None:
        rate = self.config.loop.rate_hz
        control_every = max(1, round(rate * CONTROL_POLL_S))
        event_every = max(1, round(rate * EVENT_POLL_S))
        self.pacer.start()
        watch = ParentWatch()  # a node killed outright never sets `stop`
        while True:
            if self.ticks % control_every == 0:
                if stop.is_set() or watch.gone():
                    break
                self._read_control()
            self.pacer.wait()
            if self.ticks % event_every == 0:
                self._drain_events()
            if self.eyes is not None:
                self._show_eyes(self.eyes)
            out = self.walk.tick(self.pacer.period_s)
            self.distance_m += out.speed_mps * self.pacer.period_s
            self._publish(out)
            self.ticks += 1
            self.pacer.advance()

    def _read_control(self) -> None:
        c = self.control.read_latest()
        self.offset = float(c["clock_offset"])
        if int(c["spawn_seq"]) != self.spawn_seq:
            self.spawn_seq = int(c["spawn_seq"])
            self.walk.place(float(c["spawn_x"]), float(c["spawn_y"]), float(c["spawn_yaw"]))

    def _show_eyes(self, block: EyeImageBlock) -> None:
        """The view's newest eyes go to the headset before its next frame."""
        eyes = block.newest()
        if eyes is not None:
            self.headset.present(eyes)
            self.eye_frames += 1

    def _drain_events(self) -> None:
        for event in drain(self.events):
            if isinstance(event, Impulse):
                self.impulses += 1
            elif isinstance(event, np.ndarray):
                self.walk.walkable = Walkable.from_arrays(event)

    def _publish(self, out: WalkOutput) -> None:
        r, h, w = self.record, out.head, self.walk.walker
        r["t"] = time.monotonic() + self.offset
        r["x"], r["y"], r["eye_z"] = h.x, h.y, h.z
        r["yaw"], r["pitch"], r["roll"] = h.yaw, h.pitch, h.roll
        r["vx"], r["vy"], r["ax"], r["ay"] = out.vx, out.vy, out.ax, out.ay
        r["speed_mps"], r["distance_m"] = out.speed_mps, self.distance_m
        r["stage_x"], r["stage_y"], r["stage_yaw"] = w.x, w.y, w.stage_yaw
        r["running_pace"], r["interact"], r["tracked"] = out.running_pace, out.interact, out.tracked
        r["ticks"], r["snaps"] = self.ticks, self.walk.snaps
        r["running"] = 1
        self._eyes(r)
        r["written_ns"] = time.monotonic_ns()  # last: the stamp is the moment it is published
        self.state.write(r)

    def _eyes(self, r: Any) -> None:
        eyes = self.headset.eye_fovs()
        r["eyes"] = eyes is not None
        for side, fov in zip(EYES, eyes or (), strict=False):
            for edge in EDGES:
                r[f"{side}_{edge}"] = getattr(fov, edge)

    def summary(self) -> dict[str, Any]:
        walkable = self.walk.walkable
        return {
            "ticks": self.ticks,
            "rate_hz": self.config.loop.rate_hz,
            **self.pacer.summary(),
            "distance_m": round(self.distance_m, 2),
            "snaps": self.walk.snaps,
            "walkable_segments": len(walkable) if walkable is not None else None,
            "impulses_received": self.impulses,
            "headset": type(self.headset).__name__,
            "eyes_deg": _eyes_deg(self.headset.eye_fovs()),
            "eye_frames_presented": self.eye_frames if self.eyes is not None else None,
            **_shown(self.headset),
            # control reads answered with the last copy: the node's process stalled mid-write
            "control_stale_reads": self.control.stale_reads,
        }

    def close(self) -> None:
        if self.eyes is not None:
            self.eyes.close()
        for device in (self.device, self.headset):
            if device is None:
                continue
            try:
                device.close()
            except Exception:  # closing must not hide the summary; log it
                log.exception("closing %s failed", type(device).__name__)


def _shown(headset: Any) -> dict[str, Any]:
    """What the headset's display side reports, when it has one (the sim: what it was shown)."""
    fields = ("frames_shown", "last_frame", "eye_means", "eyes_differ")
    return {f"headset_{name}": getattr(headset, name) for name in fields if hasattr(headset, name)}


def _eyes_deg(eyes: Any) -> list[list[float]] | None:
    """Each eye's (left, right, up, down) [deg] for the report, as the headset gave them."""
    if eyes is None:
        return None
    return [[round(math.degrees(a), 3) for a in (e.left, e.right, e.up, e.down)] for e in eyes]
