"""A simulated FTMS smart trainer: a flywheel, an eddy-current brake and a rider.

It is the CI backend of the bike node's trainer and the device `carlaverse calibrate trainer`
measures. The client side is the real `FtmsTrainer`; between them only FTMS bytes travel
(`ftms_codec`), exactly as over Bluetooth.

Physics, per unit of wheel speed v [m/s] at the roller:

    m_eq · dv/dt = P_rider / v − F_brake(v, r)
    F_brake(v, r) = F_0 + r/100 · F_max · (1 − exp(−v / v_c)) + k_fan · v²

m_eq is the flywheel's inertia seen at the tyre, r the commanded resistance level [%]. The
eddy-current term rises with speed and saturates (as such brakes do); F_0 is bearing and tyre
friction, k_fan the flywheel's own air drag. Physics advances lazily to the device clock in
fixed sub-steps, so it is deterministic under a manual clock; Indoor Bike Data is notified
every `notify_period_s`, as a trainer does (typically 1–4 Hz).
"""

from __future__ import annotations

import math
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.noise import OrnsteinUhlenbeck
from carlaverse.hal.trainer import ftms_codec as codec
from carlaverse.hal.trainer.ftms import FtmsTrainer, LinkHandler

Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
SUBSTEP_S = 0.005  # [s] flywheel integration step
MIN_SPEED_MPS = 0.5  # [m/s] P/v is held below this (a standing start is a push, not infinite)


class FlywheelParams(StrictStruct):
    mass_eq_kg: Positive = 12.0  # flywheel inertia seen at the tyre
    friction_n: NonNegative = 2.0  # F_0
    brake_max_n: Positive = 120.0  # F_max at 100 %
    brake_speed_mps: Positive = 4.0  # v_c
    fan_n_per_mps2: NonNegative = 0.15  # k_fan
    wheel_circumference_m: Positive = 2.105
    gear_development_m: Positive = 7.0  # metres per crank turn, for the cadence


class SimFtmsOptions(StrictStruct):
    seed: int = 0
    rider_power_w: NonNegative = 180.0  # [W] the simulated rider's mean power
    power_sigma_w: NonNegative = 10.0  # [W] its fluctuation
    notify_period_s: Positive = 0.25  # [s] Indoor Bike Data rate (4 Hz)
    flywheel: FlywheelParams = FlywheelParams()


def brake_force(p: FlywheelParams, speed_mps: float, resistance_percent: float) -> float:
    """F_brake [N] at the tyre."""
    eddy = resistance_percent / 100 * p.brake_max_n * (1 - math.exp(-speed_mps / p.brake_speed_mps))
    return p.friction_n + eddy + p.fan_n_per_mps2 * speed_mps**2


class SimFtmsPeripheral:
    """The trainer's side of the GATT link: takes control-point bytes, notifies bike data."""

    def __init__(self, options: SimFtmsOptions, t0: float) -> None:
        self.options = options
        self.t = t0  # [s] physics time
        self.t0 = t0
        self.speed_mps = 0.0
        self.distance_m = 0.0
        self.resistance_percent = 0.0
        self.power_w = 0.0  # [W] rider power now
        self.rig: tuple[float, float, float] | None = None  # a calibration motor's ramp
        self.controlled = False
        self.next_notify = t0
        self.noise = OrnsteinUhlenbeck(options.seed, 1, 0.25, 1.0, 0.5)

    def control_point(self, data: bytes) -> bytes:
        """Handle one control-point write; the response bytes (0x80, op, result)."""
        try:
            op, value = codec.decode_request(data)
        except codec.FtmsError as exc:
            op_byte = data[0] if data else 0
            reason = exc.reason == codec.FtmsReason.UNKNOWN_OP_CODE
            result = (
                codec.ResultCode.NOT_SUPPORTED if reason else codec.ResultCode.INVALID_PARAMETER
            )
            return codec.encode_response(op_byte, result)
        return codec.encode_response(op, self._apply(op, value))

    def _apply(self, op: codec.OpCode, value: object) -> codec.ResultCode:
        if op == codec.OpCode.REQUEST_CONTROL:
            self.controlled = True
            return codec.ResultCode.SUCCESS
        if not self.controlled:
            return codec.ResultCode.CONTROL_NOT_PERMITTED
        if op == codec.OpCode.SET_TARGET_RESISTANCE:
            if not 0 <= float(value) <= 100:  # type: ignore[arg-type]
                return codec.ResultCode.INVALID_PARAMETER
            self.resistance_percent = float(value)  # type: ignore[arg-type]
        elif op in (codec.OpCode.SET_TARGET_POWER, codec.OpCode.SET_SIMULATION):
            return codec.ResultCode.NOT_SUPPORTED  # a resistance-level-only trainer
        return codec.ResultCode.SUCCESS

    def drive(self, speed_mps: float, accel_mps2: float = 0.0) -> None:
        """A calibration rig's motor: from now the roller turns at speed + accel·t."""
        self.rig = (speed_mps, accel_mps2, self.t)

    def advance(self, now: float) -> list[bytes]:
        """Run the physics up to `now`; the notifications due meanwhile."""
        out = []
        while self.t + SUBSTEP_S <= now:
            self._substep(SUBSTEP_S)
            if self.t >= self.next_notify:
                self.next_notify += self.options.notify_period_s
                out.append(codec.encode_bike_data(self.sample()))
        return out

    def _substep(self, dt: float) -> None:
        o, p = self.options, self.options.flywheel
        force = brake_force(p, self.speed_mps, self.resistance_percent)
        if self.rig is not None:  # the motor imposes the speed; the power is what it takes
            speed0, accel, t_set = self.rig
            self.speed_mps = max(0.0, speed0 + accel * (self.t + dt - t_set))
            self.power_w = (force + p.mass_eq_kg * accel) * self.speed_mps
        else:
            (z,) = self.noise.at(self.t - self.t0)
            self.power_w = max(0.0, o.rider_power_w + o.power_sigma_w * float(z))
            drive = self.power_w / max(self.speed_mps, MIN_SPEED_MPS)
            self.speed_mps = max(0.0, self.speed_mps + (drive - force) / p.mass_eq_kg * dt)
        self.distance_m += self.speed_mps * dt
        self.t += dt

    def sample(self) -> codec.IndoorBikeData:
        p = self.options.flywheel
        cadence = self.speed_mps / p.gear_development_m * 60.0
        return codec.IndoorBikeData(
            speed_kmh=round(self.speed_mps * 3.6, 2),
            cadence_rpm=round(cadence * 2) / 2,
            total_distance_m=int(self.distance_m),
            resistance_level=round(self.resistance_percent),
            power_w=round(self.power_w),
            elapsed_time_s=int(self.t - self.t0),
        )


class SimLink:
    """Carries bytes between the client and the simulated peripheral, in-process."""

    def __init__(self, peripheral: SimFtmsPeripheral) -> None:
        self.peripheral = peripheral
        self.handler: LinkHandler | None = None
        self.up = False

    def start(self, handler: LinkHandler) -> None:
        self.handler = handler
        self.plug()

    def plug(self) -> None:
        """(Re)connect, as a BLE link does after an outage."""
        self.up = True
        self.peripheral.controlled = False  # a new connection must take control again
        assert self.handler is not None
        self.handler.on_connected(True)

    def unplug(self) -> None:
        self.up = False
        assert self.handler is not None
        self.handler.on_connected(False)

    def write_control(self, data: bytes) -> None:
        if self.up and self.handler is not None:
            self.handler.on_response(self.peripheral.control_point(data))

    def poll(self, now: float) -> None:
        notes = self.peripheral.advance(now)  # the flywheel turns whether or not we listen
        if self.up and self.handler is not None:
            for note in notes:
                self.handler.on_bike_data(note)

    def close(self) -> None:
        self.up = False


class SimFtmsTrainer(FtmsTrainer):
    """`backend: ftms_sim` — the client on a simulated trainer; `peripheral` is the machine."""

    Options = SimFtmsOptions

    def __init__(self, options: SimFtmsOptions, *, clock: Clock = time.monotonic) -> None:
        self.peripheral = SimFtmsPeripheral(options, clock())
        self.sim_link = SimLink(self.peripheral)
        super().__init__(options, self.sim_link, clock=clock)

    def drive(self, speed_mps: float, accel_mps2: float = 0.0) -> None:
        """A calibration rig's motor, starting now on the device clock.

        The peripheral's physics runs lazily, up to the last poll; a ramp anchored there
        would start as far into itself as the clock has run since (a 2 s settle at
        0.48 m/s² began the up-ramp at 1.47 m/s, not 0.5, and left no up-ramp sample for
        the table's 1 m/s row). So the physics is brought to now first."""
        self.sim_link.poll(self.clock())
        self.peripheral.drive(speed_mps, accel_mps2)

    def release(self) -> None:
        """The rig lets go of the roller now: from here the rider and the brake move it."""
        self.sim_link.poll(self.clock())
        self.peripheral.rig = None
