"""The bike node's physics + haptics loop body, free of any network or device.

`BikeLoop.step(dt, wheel_speed_mps, steer_axis, tailwind_mps, impulses)` runs one tick:

    impulses → single-track bicycle → riding resistance (+ the missing inertia) → trainer
    command (calibrated table, clipped to what the trainer renders) → fork feel

and returns a `BikeOutput`: the pose (the lean as ISO 8855 roll, absolute velocity), the
resistance force and the trainer's resistance level, and the fork's FFB command. Whoever runs
the loop (the loop process, a test, a benchmark) owns the clock, the devices and the fabric,
and sets `grade_percent` when the road under the bike changes (the scenario's grades).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from carlaverse_nodes.bike.config import BikeNodeConfig
from carlaverse_nodes.bike.fork_feel import ForkFeel
from carlaverse_nodes.bike.trainer_command import TrainerCommand, TrainerLimit

from carlaverse.hal.ffb_packet import FfbCommand
from carlaverse.hal.trainer.resistance_table import ResistanceTable
from carlaverse.messages import Impulse, Pose
from carlaverse.physics.bicycle import Bicycle, WheelReading
from carlaverse.physics.impulse import ImpulseInbox
from carlaverse.physics.resistance import resistance_force


@dataclass(slots=True)
class BikeOutput:
    t: float  # [s] loop clock (session time when a clock is injected)
    x: float  # [m] world frame
    y: float
    yaw: float  # [rad]
    roll: float  # [rad] ISO 8855, right side down positive: a left lean is negative
    vx: float  # [m/s] world frame
    vy: float
    yaw_rate: float  # [rad/s]
    ax: float  # [m/s²] world frame
    ay: float
    speed_mps: float  # [m/s] along the heading
    steer_rad: float  # [rad] fork angle
    resistance_n: float  # [N] F_res of the road under the wheel
    resistance_percent: float  # [%] what the trainer is told
    fallen: bool
    ffb: FfbCommand
    impulses_applied: int
    trainer_limit: TrainerLimit = TrainerLimit.NONE  # what the trainer cannot render now
    trainer_missing_n: float = 0.0  # [N] wanted minus rendered force at the tyre

    def pose(self, seq: int = 0) -> Pose:
        """The pose telemetry sample: planar, the lean as roll, absolute velocity."""
        return Pose(
            seq, self.t, self.x, self.y, roll=self.roll, yaw=self.yaw, vx=self.vx,
            vy=self.vy, wz=self.yaw_rate, ax=self.ax, ay=self.ay,
        )  # fmt: skip


class BikeLoop:
    """Bicycle physics, resistance → trainer command, fork feel."""

    def __init__(self, config: BikeNodeConfig, table: ResistanceTable) -> None:
        self.config = config
        self.table = table
        self.bike = Bicycle(config.bicycle)
        self.wheel = WheelReading(config.bicycle)  # the sensor's steps, as a body can ride them
        self.fork = ForkFeel(config.fork, config.bicycle)
        self.trainer = TrainerCommand(table, config.bicycle.mass_kg, config.trainer_feel)
        self.t = 0.0
        self.inbox = ImpulseInbox(config.bicycle.mass_kg)
        self.grade_percent = config.road.grade_percent  # [%] along the heading, uphill positive

    def place(self, x: float, y: float, yaw: float) -> None:
        self.bike.place(x, y, yaw)
        self.wheel.reset()  # a spawn: the rider's next reading is taken as it is

    def step(self, dt: float, wheel_speed_mps: float, steer_axis: float, tailwind_mps: float,
             impulses: Iterable[Impulse] = (), now: float | None = None) -> BikeOutput:  # fmt: skip
        """One tick of dt [s]; `now` is session time (else the loop's own accumulated time)."""
        self.t += dt
        now = self.t if now is None else now
        applied = self._collisions(impulses, now)
        p = self.config.bicycle
        riding = self.wheel.follow(wheel_speed_mps, dt, stopped=self.bike.state.hold_s > 0.0)
        s = self.bike.step(dt, riding, steer_axis * p.max_steer_rad)
        force = resistance_force(
            self.config.resistance, p.mass_kg, s.speed_mps, self.grade_percent, tailwind_mps
        )
        target = self.trainer.update(dt, wheel_speed_mps, force)  # the brake's own speed
        ffb = self.fork.update(dt, s.speed_mps, s.steer_rad, self.config.road.roughness)
        roll = -s.lean_rad  # the bicycle's lean is positive to the left; ISO roll to the right
        return BikeOutput(
            now, s.x, s.y, s.yaw, roll, s.vx, s.vy, s.yaw_rate, s.ax, s.ay, s.speed_mps,
            s.steer_rad, force, target.percent, s.fallen, ffb, applied, target.limit,
            target.missing_n,
        )  # fmt: skip

    @property
    def impulses_dropped(self) -> int:
        return self.inbox.dropped

    def _collisions(self, impulses: Iterable[Impulse], now: float) -> int:
        self.inbox.accept(impulses)
        due = self.inbox.due(now)
        for impulse in due:
            hit = self.bike.apply_impulse(impulse.impulse)
            self.fork.add_jolt(hit.magnitude(), hit.dv_lateral_mps)
        return len(due)
