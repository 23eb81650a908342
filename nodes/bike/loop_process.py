"""The bike node's loop process: devices → BikeLoop → shared state, fork FFB, trainer.

It runs at `loop.rate_hz` (200 Hz) in a process of its own, like the drive node's loop, and
never touches the network. Its timing (sleep, then spin to each deadline; the period error
measured every tick) and priority come from `carlaverse.realtime`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

from carlaverse_nodes.bike.bike_loop import BikeLoop, BikeOutput
from carlaverse_nodes.bike.config import BikeNodeConfig
from carlaverse_nodes.bike.shared_state import CONTROL, STATE
from carlaverse_nodes.loop_events import drain
from carlaverse_nodes.map_route import DriverRoute

from carlaverse.hal import open_ffb, open_input, open_speed_sensor, open_trainer
from carlaverse.hal.trainer.resistance_table import ResistanceTable
from carlaverse.messages import Impulse
from carlaverse.physics.resistance import tailwind
from carlaverse.procs import ParentWatch
from carlaverse.realtime import Pacer, raise_priority
from carlaverse.shm import SharedBlock, new_record

log = logging.getLogger(__name__)

CONTROL_POLL_S = 0.05  # [s] re-read clock offset, spawn, wind and grade
EVENT_POLL_S = 0.005  # [s] look at the event queue


@dataclass(frozen=True)
class BikeLoopSpec:
    config: BikeNodeConfig
    table: ResistanceTable
    state_block: str
    control_block: str


def run_bike_loop(spec: BikeLoopSpec, events: Any, results: Any, stop: Any) -> None:
    """Entry point of the loop process."""
    raise_priority(spec.config.loop.realtime_priority)
    state = SharedBlock(spec.state_block, STATE)
    control = SharedBlock(spec.control_block, CONTROL)
    runner = BikeRunner(spec, state, control, events)
    try:
        runner.run(stop)
    finally:
        results.put(runner.summary())
        runner.close()
        state.close()
        control.close()


class BikeRunner:
    def __init__(self, spec: BikeLoopSpec, state: SharedBlock, control: SharedBlock,
                 events: Any) -> None:  # fmt: skip
        config = spec.config
        self.config, self.state, self.control, self.events = config, state, control, events
        self.offset = float(control.read()["clock_offset"])
        self.input = open_input(config.input, source="input")
        self.ffb = open_ffb(config.ffb)
        self.trainer = open_trainer(config.trainer)
        self.sensor = (
            open_speed_sensor(config.speed_sensor)
            if config.speed_source == "speed_sensor"
            else None
        )
        self.loop = BikeLoop(config, spec.table)
        self.record = new_record(STATE)
        self.pacer = Pacer(config.loop.rate_hz)
        self.spawn_seq = 0
        self.wind = (0.0, 0.0)  # [m/s, deg from]
        self.pending: list[Impulse] = []
        self.ticks = self.ffb_sent = self.impulses = 0
        self.distance_m = 0.0
        self.trainer_state = self.trainer.read()

    def run(self, stop: Any) -> None:
        cfg, pacer = self.config.loop, self.pacer
        every = lambda hz: max(1, round(cfg.rate_hz / hz))  # noqa: E731
        ffb_every, trainer_every = every(cfg.ffb_rate_hz), every(cfg.trainer_rate_hz)
        control_every, event_every = every(1 / CONTROL_POLL_S), every(1 / EVENT_POLL_S)
        pacer.start()
        watch = ParentWatch()  # a node killed outright never sets `stop`
        while True:
            if self.ticks % control_every == 0:
                if stop.is_set() or watch.gone():
                    break
                self._read_control()
            pacer.wait()
            if self.ticks % event_every == 0:
                self._drain_events()
            out = self._tick(pacer.period_s)
            if self.ticks % ffb_every == 0:
                self.ffb.send(out.ffb)
                self.ffb_sent += 1
            if self.ticks % trainer_every == 0:
                self.trainer.set_resistance(out.resistance_percent)
            self.ticks += 1
            pacer.advance()

    def _tick(self, dt: float) -> BikeOutput:
        self.trainer_state = self.trainer.read()
        speed = self._wheel_speed()
        steer = self.input.poll().axes.get("steer", 0.0)
        s = self.loop.bike.state
        wind = tailwind(self.wind[0], self.wind[1], s.yaw)
        impulses, self.pending = self.pending, []
        out = self.loop.step(dt, speed, steer, wind, impulses, time.monotonic() + self.offset)
        observe = getattr(self.input, "observe", None)
        if observe is not None:  # the scripted rider sees where the bike is
            observe(out.x, out.y, out.yaw, out.speed_mps)
        self.impulses += out.impulses_applied
        self.distance_m += out.speed_mps * dt
        self._publish(out)
        return out

    def _wheel_speed(self) -> float:
        if self.sensor is not None:
            return self.sensor.read().speed_mps
        return self.trainer_state.speed_mps or 0.0

    def _drain_events(self) -> None:
        for event in drain(self.events):
            if isinstance(event, Impulse):
                self.pending.append(event)
            elif isinstance(event, DriverRoute):  # the scripted rider's, along the map
                event.apply([self.input])

    def _read_control(self) -> None:
        c = self.control.read_latest()
        self.offset = float(c["clock_offset"])
        self.wind = (float(c["wind_speed_mps"]), float(c["wind_from_deg"]))
        self.loop.grade_percent = float(c["grade_percent"])
        if int(c["spawn_seq"]) != self.spawn_seq:
            self.spawn_seq = int(c["spawn_seq"])
            self.loop.place(float(c["spawn_x"]), float(c["spawn_y"]), float(c["spawn_yaw"]))

    def _publish(self, out: BikeOutput) -> None:
        r, ts = self.record, self.trainer_state
        for name in ("t", "x", "y", "yaw", "vx", "vy", "yaw_rate", "ax", "ay", "speed_mps",
                     "steer_rad", "resistance_n", "resistance_percent", "fallen"):  # fmt: skip
            r[name] = getattr(out, name)
        r["roll"] = out.roll
        r["trainer_limit"], r["trainer_missing_n"] = out.trainer_limit, out.trainer_missing_n
        r["power_w"], r["cadence_rpm"] = ts.power_w, ts.cadence_rpm
        r["grade_percent"] = self.loop.grade_percent
        r["ticks"], r["ffb_sent"], r["impulses_applied"] = self.ticks, self.ffb_sent, self.impulses
        r["running"] = 1
        r["written_ns"] = time.monotonic_ns()  # last: the stamp is the moment it is published
        self.state.write(r)

    def summary(self) -> dict[str, Any]:
        return {
            "ticks": self.ticks,
            "rate_hz": self.config.loop.rate_hz,
            **self.pacer.summary(),
            "ffb_sent": self.ffb_sent,
            "impulses_applied": self.impulses,
            "impulses_dropped": self.loop.impulses_dropped,  # non-finite or impossible Δv
            "distance_m": round(self.distance_m, 2),
            "resistance_percent": round(float(self.record["resistance_percent"]), 2),
            "trainer": dict(getattr(self.trainer, "counters", {})),
            "trainer_limits": self.loop.trainer.summary(),  # what it could not render
            # control reads answered with the last copy: the node's process stalled mid-write
            "control_stale_reads": self.control.stale_reads,
        }

    def close(self) -> None:
        devices = [self.input, self.ffb, self.trainer, *([self.sensor] if self.sensor else [])]
        for device in devices:
            try:
                device.close()
            except Exception:  # closing must not hide the summary; log it
                log.exception("closing %s failed", type(device).__name__)
