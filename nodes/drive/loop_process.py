"""The drive node's control process: devices → DriveLoop → shared state, FFB and motion at 1 kHz.

It runs in a process of its own (a busy Python thread would delay the fabric's callbacks by
up to the interpreter's 5 ms switch interval, and vice versa), never touches the network, and
exchanges state with the fabric process only through shared memory. Impulses, overrides and
the scenario's road surface arrive on a queue, polled every few ticks without waiting.

Timing and priority come from `carlaverse.realtime`: sleep until shortly before each
deadline, then spin to it; the error between the deadline and the actual wake-up is measured
every tick and reported.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass
from typing import Any

from carlaverse_nodes.drive.config import DriveNodeConfig, input_configs
from carlaverse_nodes.drive.shared_state import CONTROL, INDICATORS, STATE
from carlaverse_nodes.drive.touch import TouchButtons, TouchPress
from carlaverse_nodes.drive.vehicle_loop import DriveLoop, LoopOutput
from carlaverse_nodes.loop_events import drain
from carlaverse_nodes.map_route import DriverRoute

from carlaverse.hal import FfbCommand, MotionFrame, open_ffb, open_input, open_motion
from carlaverse.messages import Impulse, Override
from carlaverse.physics.params import VehicleParams
from carlaverse.physics.road_surface import RoadSurface
from carlaverse.procs import ParentWatch
from carlaverse.realtime import Pacer, raise_priority
from carlaverse.shm import SharedBlock, new_record

log = logging.getLogger(__name__)

EVENT_POLL_TICKS = 5  # look at the event queue every 5 ms
CONTROL_POLL_TICKS = 50  # re-read clock offset and spawn every 50 ms


@dataclass(frozen=True)
class LoopSpec:
    config: DriveNodeConfig
    vehicle: VehicleParams
    state_block: str
    control_block: str
    duration_s: float | None = None


@dataclass
class MergedInput:
    """Several devices' channels as one (wheel, pedals, button box: later devices win)."""

    axes: dict[str, float]
    buttons: dict[str, bool]


def run_loop(spec: LoopSpec, events: Any, results: Any, stop: Any) -> None:
    """Entry point of the control process."""
    raise_priority(spec.config.loop.realtime_priority)
    state = SharedBlock(spec.state_block, STATE)
    control = SharedBlock(spec.control_block, CONTROL)
    runner = _Runner(spec, state, control, events)
    try:
        runner.run(stop)
    finally:
        results.put(runner.summary())
        runner.close()
        state.close()
        control.close()


class _Runner:
    def __init__(
        self, spec: LoopSpec, state: SharedBlock, control: SharedBlock, events: Any
    ) -> None:
        config = spec.config
        self.spec = spec
        self.state, self.control, self.events = state, control, events
        self.offset = float(control.read()["clock_offset"])
        self.inputs = [open_input(c, source="input") for c in input_configs(config)]
        self.ffb = open_ffb(config.ffb)
        self.motion = open_motion(config.motion)
        self.loop = DriveLoop(config, spec.vehicle, clock=self.session_now)
        self.scripted = any(c.backend == "sim" for c in input_configs(config))
        if self.scripted:
            self.loop.engage_drive()
        self.record = new_record(STATE)
        self.pacer = Pacer(config.loop.rate_hz)
        self.spawn_seq = 0
        self.pending: list[Impulse] = []
        self.touch = TouchButtons()  # the web HMI's taps
        self.ffb_sent = self.motion_sent = self.impulses = self.ticks = 0
        self.motion_clipped = 0  # frames sent clipped to the motion device's limits
        self.surface_features: int | None = None  # the scenario's bumps, kerbs, potholes
        self.distance_m = 0.0

    def session_now(self) -> float:
        return time.monotonic() + self.offset

    def run(self, stop: Any) -> None:
        cfg, pacer = self.spec.config.loop, self.pacer
        ffb_every = max(1, round(cfg.rate_hz / cfg.ffb_rate_hz))
        motion_every = max(1, round(cfg.rate_hz / cfg.motion_rate_hz))
        started = pacer.start()
        end = started + self.spec.duration_s if self.spec.duration_s else float("inf")
        watch = ParentWatch()  # a node killed outright never sets `stop`
        while True:
            if self.ticks % CONTROL_POLL_TICKS == 0:
                if stop.is_set() or watch.gone() or pacer.next_t >= end:
                    break
                self._read_control()
            pacer.wait()
            out = self._tick(pacer.period_s)
            if self.ticks % ffb_every == 0:
                self.ffb.send(FfbCommand(**dataclasses.asdict(out.ffb)))
                self.ffb_sent += 1
            if self.ticks % motion_every == 0:
                m = out.motion
                frame = MotionFrame(m.roll, m.pitch, m.heave, m.rpm, m.torque)
                # Beyond the device's limits a frame is clipped and counted, never raised into
                # the loop. The config load refused cueing clamps wider than the device's
                # limits, so what reaches this is engine rpm and torque, which pass unclamped.
                self.motion_clipped += self.motion.send_clipped(frame)
                self.motion_sent += 1
            self.ticks += 1
            pacer.advance()

    def _tick(self, dt: float) -> LoopOutput:
        raw = self._poll_inputs()
        if self.ticks % EVENT_POLL_TICKS == 0:
            self._drain_events()
        impulses, self.pending = self.pending, []
        out = self.loop.step(dt, raw, impulses)
        self.impulses += out.impulses_applied
        self.distance_m += abs(out.speed_mps) * dt
        if self.scripted:
            for device in self.inputs:
                observe = getattr(device, "observe", None)
                if observe is not None:
                    observe(out.x, out.y, out.yaw, out.speed_mps)
        self._publish_state(out)
        return out

    def _poll_inputs(self) -> MergedInput:
        touched = self.touch.buttons()
        if len(self.inputs) == 1 and touched is None:
            s = self.inputs[0].poll()
            return MergedInput(s.axes, s.buttons)
        axes: dict[str, float] = {}
        buttons: dict[str, bool] = {}
        for device in self.inputs:
            s = device.poll()
            axes.update(s.axes)
            buttons.update(s.buttons)
        buttons.update(touched or {})
        return MergedInput(axes, buttons)

    def _drain_events(self) -> None:
        for event in drain(self.events):
            if isinstance(event, Impulse):
                self.pending.append(event)
            elif isinstance(event, Override):
                self.loop.submit_override(event)
            elif isinstance(event, TouchPress):
                self.touch.tap(event.action)
            elif isinstance(event, RoadSurface):  # the scenario's, once per join
                self.loop.set_surface(event)
                self.surface_features = event.feature_count()
            elif isinstance(event, DriverRoute):  # the scripted driver's, along the map
                event.apply(self.inputs)

    def _read_control(self) -> None:
        c = self.control.read_latest()
        self.offset = float(c["clock_offset"])
        if int(c["spawn_seq"]) != self.spawn_seq:
            self.spawn_seq = int(c["spawn_seq"])
            self.loop.place(float(c["spawn_x"]), float(c["spawn_y"]), float(c["spawn_yaw"]))
            if self.scripted:
                self.loop.engage_drive()

    def _publish_state(self, out: LoopOutput) -> None:
        r = self.record
        r["t"], r["x"], r["y"], r["yaw"] = out.t, out.x, out.y, out.yaw
        r["vx"], r["vy"], r["yaw_rate"], r["ax"], r["ay"] = (
            out.vx,
            out.vy,
            out.yaw_rate,
            out.ax,
            out.ay,
        )
        r["speed_mps"], r["steer_rad"], r["rpm"] = out.speed_mps, out.steer_rad, out.rpm
        r["engine_torque_nm"], r["throttle"], r["brake"] = (
            out.engine_torque_nm,
            out.throttle,
            out.brake,
        )
        r["gear"], r["lights"] = out.gear, out.lights
        r["indicator"] = INDICATORS.index(out.indicator) if out.indicator in INDICATORS else 0
        r["blink_on"], r["lca_active"] = out.blink_on, out.lca_active
        r["adas_active"] = bool(out.adas.sources)
        r["cruise_active"], r["cruise_speed_mps"] = (
            out.adas.cruise_active,
            out.adas.cruise_speed_mps,
        )
        r["brake_override"] = out.adas.driver_brake_override
        r["ticks"], r["period_error_us"] = self.ticks, self.pacer.last_error_s * 1e6
        r["max_period_error_us"] = self.pacer.max_error_s * 1e6
        r["ffb_sent"], r["motion_sent"], r["impulses_applied"] = (
            self.ffb_sent,
            self.motion_sent,
            self.impulses,
        )
        r["running"] = 1
        r["written_ns"] = time.monotonic_ns()  # last: the stamp is the moment it is published
        self.state.write(r)

    def summary(self) -> dict[str, Any]:
        return {
            "ticks": self.ticks,
            **self.pacer.summary(),
            "ffb_sent": self.ffb_sent,
            "motion_sent": self.motion_sent,
            "motion_clipped": self.motion_clipped,  # clipped to the device's MotionLimits
            "impulses_applied": self.impulses,
            "impulses_dropped": self.loop.impulses_dropped,  # non-finite or impossible Δv
            "distance_m": round(self.distance_m, 2),
            "surface_features": self.surface_features,  # None: no scenario surface arrived
            # control reads answered with the last copy: the node's process stalled mid-write
            "control_stale_reads": self.control.stale_reads,
        }

    def close(self) -> None:
        for device in (*self.inputs, self.ffb, self.motion):
            try:
                device.close()
            except Exception:  # closing must not hide the summary; log it
                log.exception("closing %s failed", type(device).__name__)
