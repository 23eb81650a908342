"""The drive node's control + physics + haptics loop body, free of any network or device.

`DriveLoop.step(dt, raw_input, impulses)` runs one tick:

    controls → automotive logic (gears, indicators, lights) → ADAS arbitration →
    collision impulses → car physics and vertical motion over the road (sub-stepped) →
    steering feel → motion cueing → output

and returns a `LoopOutput`: the pose and dashboard telemetry, the FFB command values and the
motion cue. Whoever runs the loop (the node runtime, a test, a benchmark) owns the clock, the
devices and the fabric; this class only computes. It is cheap enough for 1 kHz in pure
Python (see tools/bench/drive_loop.py and docs/benchmarks.md).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import cast

from carlaverse_nodes.drive.adas import AdasArbiter, AdasState
from carlaverse_nodes.drive.config import DriveNodeConfig
from carlaverse_nodes.drive.controls import H_SHIFTER_ACTIONS, Controls, DriverCommand, RawInput
from carlaverse_nodes.drive.indicators import Indicators
from carlaverse_nodes.drive.lights import Lights

from carlaverse.messages import EgoState, Impulse, Indicator, Override, Pose
from carlaverse.physics.car import Car
from carlaverse.physics.impulse import ImpulseInbox
from carlaverse.physics.motion_cueing import MotionCue, MotionCueing
from carlaverse.physics.params import VehicleParams
from carlaverse.physics.road_surface import RoadProfile, RoadSurface
from carlaverse.physics.steering_feel import FfbCommandValues, SteeringFeel
from carlaverse.physics.vertical import VerticalDynamics, VerticalState

log = logging.getLogger(__name__)

MAX_PHYSICS_DT_S = 0.005  # [s] a late tick is sub-stepped so the chassis stays stable


@dataclass(slots=True)
class LoopOutput:
    """One tick's result: pose, dashboard telemetry, FFB command and motion cue."""

    t: float  # [s] loop clock (session time when the runtime injects it)
    x: float  # [m] world frame
    y: float  # [m]
    yaw: float  # [rad]
    vx: float  # [m/s] world frame
    vy: float  # [m/s]
    yaw_rate: float  # [rad/s]
    ax: float  # [m/s²] world frame
    ay: float  # [m/s²]
    speed_mps: float  # [m/s] forward speed, negative when reversing
    steer_rad: float  # [rad] road-wheel angle
    rpm: float  # [1/min]
    gear: int  # −1 reverse, 0 neutral, 1.. forward
    engine_torque_nm: float  # [N·m]
    throttle: float  # effective pedals after ADAS arbitration, 0..1
    brake: float
    indicator: str  # what others see: off | left | right | hazard
    indicator_state: str  # the machine's own state (hazard_left, ...)
    blink_on: bool  # the flasher's lamp phase, for the dashboard
    lights: int  # LIGHT_* bitmask (carlaverse.messages)
    lca_active: bool  # lane-change assist armed (gates the indicator reset)
    adas: AdasState
    ffb: FfbCommandValues
    motion: MotionCue
    state_changed: bool  # lights/indicator/gear/ADAS differ from the last tick: publish
    impulses_applied: int  # collision impulses applied in this tick
    vertical: VerticalState  # heave, pitch and wheel shake over the road profile

    @property
    def speed_kmh(self) -> float:
        return abs(self.speed_mps) * 3.6

    def pose(self, seq: int, t: float) -> Pose:
        """The pose telemetry sample for this tick (planar: z, roll, pitch are 0)."""
        return Pose(seq, t, self.x, self.y, 0.0, 0.0, 0.0, self.yaw, self.vx, self.vy, 0.0,
                    0.0, 0.0, self.yaw_rate, self.ax, self.ay, 0.0)  # fmt: skip

    def ego_state(self, seq: int, t: float) -> EgoState:
        on = self.indicator in ("left", "right", "hazard")
        indicator: Indicator = cast("Indicator", self.indicator) if on else "off"
        return EgoState(seq, t, self.lights, indicator, self.gear, self.speed_mps,
                        self.adas.sources)  # fmt: skip


class DriveLoop:
    """Controls, automotive logic, ADAS, car physics, steering feel and motion cueing."""

    def __init__(
        self,
        config: DriveNodeConfig,
        vehicle: VehicleParams,
        clock: Callable[[], float] | None = None,
    ) -> None:
        self.config = config
        self.vehicle = vehicle
        self.car = Car(vehicle)
        self.controls = Controls(config.controls)
        self.adas = AdasArbiter(config.adas)
        self.indicators = Indicators(config.loop.blink_period_s)
        self.lights = Lights()
        self.steering_feel = SteeringFeel(
            config.steering_feel,
            vehicle.tyres.pneumatic_trail_m,
            vehicle.steering.ratio,
            vehicle.engine.redline_rpm,
            vehicle.engine.cylinders,
        )
        self.motion_cueing = MotionCueing(config.motion_cueing)
        self.vertical = VerticalDynamics(
            vehicle.body, vehicle.suspension, self._road_profile(RoadSurface())
        )
        self._clock = clock
        self.t = 0.0  # [s] accumulated loop time, used when no clock is injected
        self.lca_active = False
        self._manual = vehicle.transmission.mode == "manual"
        self.inbox = ImpulseInbox(vehicle.body.mass_kg)
        self._last_state: tuple[object, ...] = ()
        self._substeps = config.loop.physics_substeps

    def now(self) -> float:
        """Session time when a clock was injected, else the loop's own accumulated time."""
        return self._clock() if self._clock is not None else self.t

    def place(self, x: float, y: float, yaw: float, speed_mps: float = 0.0) -> None:
        """Put the car at the spawn pose the authority granted."""
        self.car.place(x, y, yaw, speed_mps)
        self._road_moved()

    def set_surface(self, surface: RoadSurface) -> None:
        """The scenario's road surface: its features, and its roughness where it names one."""
        self.vertical.profile = self._road_profile(surface)
        self._road_moved()

    def _road_moved(self) -> None:
        """Settle on the road now under the wheels instead of feeling the jump to it."""
        self.vertical.place()
        self.motion_cueing.road_moved()

    def _road_profile(self, surface: RoadSurface) -> RoadProfile:
        road = self.config.road
        return RoadProfile.build(surface, road.roughness_class, road.roughness_seed)

    def engage_drive(self) -> None:
        """Select D (automatic) or first gear (manual), e.g. for a scripted start."""
        self.car.powertrain.select(1)

    def submit_override(self, override: Override) -> bool:
        """The local ADAS API (the fabric's `ego/<id>/override` lands here too)."""
        return self.adas.submit(override, self.now())

    def step(self, dt: float, raw_input: RawInput, impulses: Iterable[Impulse] = ()) -> LoopOutput:
        """Run one loop tick of dt [s]."""
        self.t += dt
        now = self.now()
        cmd = self.controls.read(raw_input)
        self._automotive(cmd)
        car = self.car
        s = car.state
        steer, throttle, brake = self.adas.apply(cmd.steer, cmd.throttle, cmd.brake, s.vx, dt, now)
        applied = self._collisions(impulses, now)
        self._physics(dt, steer, throttle, brake, cmd.clutch)
        pt = car.powertrain
        vertical = self.vertical.state()
        ffb = self.steering_feel.update(
            dt, s.vx, s.alpha_front, s.fz_front, pt.rpm, vertical.wheel_accel_mps2,
            self.adas.state.lane_keep_torque_nm,
        )  # fmt: skip
        motion = self.motion_cueing.update(
            dt, s.ax, s.ay, vertical.heave_accel_mps2, s.vx, brake, steer, pt.rpm,
            pt.engine_torque_nm, vertical.pitch_rad,
        )  # fmt: skip
        blink_on = self.indicators.advance(dt)
        lights = (
            self.lights.bits("flash" in cmd.held, brake, pt.gear) | self.indicators.light_bits()
        )
        return self._output(now, throttle, brake, blink_on, lights, ffb, motion, applied, vertical)

    # ------------------------------------------------------------------ parts of a tick

    def _automotive(self, cmd: DriverCommand) -> None:
        pressed = cmd.pressed
        if pressed:
            if "lane_change_assist" in pressed:
                self.lca_active = not self.lca_active
            self.indicators.handle(pressed, self.lca_active)
            self.lights.handle(pressed)
            self._gear_requests(pressed)
        if self._manual and self.controls.has_h_shifter:
            self._h_shifter(cmd.held)

    def _gear_requests(self, pressed: frozenset[str]) -> None:
        pt, speed = self.car.powertrain, self.car.state.vx
        if "gear_up" in pressed:
            pt.shift_up()
        if "gear_down" in pressed:
            pt.shift_down(speed)
        if "gear_reverse" in pressed:
            pt.select(-1, speed)
        if "gear_neutral" in pressed:
            pt.select(0)
        if "gear_drive" in pressed:
            pt.select(1, speed)

    def _h_shifter(self, held: frozenset[str]) -> None:
        """An H-shifter's gate is a level, not an edge: out of every gate means neutral."""
        gear = next((i + 1 for i, a in enumerate(H_SHIFTER_ACTIONS) if a in held), 0)
        if gear == 0 and "gear_reverse" in held:
            gear = -1
        if gear != self.car.powertrain.gear:
            self.car.powertrain.select(gear, self.car.state.vx)

    @property
    def impulses_dropped(self) -> int:
        return self.inbox.dropped

    def _collisions(self, impulses: Iterable[Impulse], now: float) -> int:
        self.inbox.accept(impulses)
        due = self.inbox.due(now)
        for impulse in due:
            response = self.car.apply_impulse(impulse.impulse, impulse.point)
            self.steering_feel.jolt(response)
            self.motion_cueing.collision(response)
        return len(due)

    def _physics(
        self, dt: float, steer: float, throttle: float, brake: float, clutch: float
    ) -> None:
        n = max(self._substeps, math.ceil(dt / MAX_PHYSICS_DT_S))
        h = dt / n
        mu = self.config.road.mu_scale
        s = self.car.state
        for _ in range(n):
            self.car.step(h, steer, throttle, brake, clutch, mu)
            self.vertical.step(h, s.x, s.y, s.yaw, s.vx)

    def _output(
        self,
        now: float,
        throttle: float,
        brake: float,
        blink_on: bool,
        lights: int,
        ffb: FfbCommandValues,
        motion: MotionCue,
        applied: int,
        vertical: VerticalState,
    ) -> LoopOutput:
        s, pt, adas = self.car.state, self.car.powertrain, self.adas.state
        c, si = math.cos(s.yaw), math.sin(s.yaw)
        indicator = self.indicators.visible()
        key = (lights, indicator, pt.gear, adas.sources, adas.cruise_active)
        changed = key != self._last_state
        self._last_state = key
        return LoopOutput(
            now, s.x, s.y, s.yaw, s.vx * c - s.vy * si, s.vx * si + s.vy * c, s.yaw_rate,
            s.ax * c - s.ay * si, s.ax * si + s.ay * c, s.vx, s.steer, pt.rpm, pt.gear,
            pt.engine_torque_nm, throttle, brake, indicator, self.indicators.state.value,
            blink_on, lights, self.lca_active, adas, ffb, motion, changed, applied, vertical,
        )  # fmt: skip
