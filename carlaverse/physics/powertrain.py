"""Engine, clutch and gearbox: from throttle, clutch pedal and wheel speed to wheel torque.

Model, chosen to be cheap at 1 kHz and well-behaved at standstill:
- Engine torque = throttle · full-load curve(rpm) − (1 − throttle) · drag(rpm); fuel is cut
  above the redline.
- The clutch (or, in automatic mode, the torque converter) slips while the gearbox side turns
  slower than the launch speed idle + throttle·(launch − idle): the engine is held there and
  passes its (positive) torque on, so a closed throttle never pushes a stopped car and a
  manual car cannot stall. Once the gearbox side is faster the clutch locks and the engine
  follows the wheels, adding its inertia to the car's.
- Automatic: shift points linear in throttle, torque interrupted for `shift_time_s`.
  Manual: the driver shifts; the clutch pedal scales the transmitted torque.

Gear numbering (telemetry and EgoState): −1 reverse, 0 neutral, 1..n forward.
"""

from __future__ import annotations

import math

from carlaverse.physics.filters import interp
from carlaverse.physics.params import Engine, Transmission

RADPS_TO_RPM = 60.0 / (2.0 * math.pi)
FREE_REV_TAU_S = 0.25  # engine spin-up/down time constant when declutched [s]
REVERSE_MAX_SPEED_MPS = 1.0  # reverse only engages below this forward speed [m/s]


class EngineModel:
    """Torque of the engine alone, from its full-load curve and its drag."""

    __slots__ = ("_drag0", "_drag1", "_rpms", "_torques", "idle_rpm", "redline_rpm")

    def __init__(self, params: Engine) -> None:
        self._rpms = tuple(p[0] for p in params.torque_curve)
        self._torques = tuple(p[1] for p in params.torque_curve)
        self._drag0, self._drag1 = params.drag_torque_nm
        self.idle_rpm = params.idle_rpm
        self.redline_rpm = params.redline_rpm

    def torque(self, rpm: float, throttle: float) -> float:
        """Crank torque [N·m] at `rpm` and throttle 0..1."""
        full = interp(rpm, self._rpms, self._torques) if rpm < self.redline_rpm else 0.0
        drag = self._drag0 + self._drag1 * rpm * 0.001
        return throttle * full - (1.0 - throttle) * drag


class Powertrain:
    """Engine + clutch + gearbox + final drive. Call `step` once per physics step."""

    def __init__(self, engine: Engine, transmission: Transmission) -> None:
        self.engine = EngineModel(engine)
        self.params = transmission
        self.engine_inertia_kgm2 = engine.inertia_kgm2
        self.automatic = transmission.mode == "automatic"
        self.gear = 0
        self.rpm = engine.idle_rpm  # [rpm]
        self.engine_torque_nm = 0.0  # crank torque last step [N·m]
        self.reflected_inertia_kgm2 = 0.0  # engine inertia seen at the wheels [kg·m²]
        self._shift_timer_s = 0.0
        self._cooldown_s = 0.0
        self._n = len(transmission.ratios)

    # ------------------------------------------------------------------ driver requests

    def shift_up(self) -> None:
        """Manual: next gear. Automatic: selector R → N → D."""
        if self.automatic and self.gear >= 1:
            return
        self._engage(min(self.gear + 1, self._n), 0.0)

    def shift_down(self, forward_speed_mps: float) -> None:
        """Manual: previous gear. Automatic: selector D → N → R (R only when nearly stopped)."""
        target = 0 if self.automatic and self.gear >= 1 else self.gear - 1
        if target < 0 and forward_speed_mps > REVERSE_MAX_SPEED_MPS:
            return
        self._engage(max(target, -1), 0.0)

    def select(self, gear: int, forward_speed_mps: float = 0.0) -> None:
        """Put the gearbox in `gear` (−1..n) directly, e.g. from an H-shifter."""
        if gear < 0 and forward_speed_mps > REVERSE_MAX_SPEED_MPS:
            return
        self._engage(max(-1, min(gear, self._n)), 0.0)

    def _engage(self, gear: int, shift_time_s: float) -> None:
        if gear != self.gear:
            self.gear = gear
            self._shift_timer_s = shift_time_s

    # ------------------------------------------------------------------ physics step

    def ratio(self) -> float:
        """Overall ratio engine/wheel of the current gear, signed (negative in reverse)."""
        if self.gear == 0:
            return 0.0
        if self.gear < 0:
            return -self.params.reverse_ratio * self.params.final_drive
        return self.params.ratios[self.gear - 1] * self.params.final_drive

    def step(self, dt: float, throttle: float, clutch: float, wheel_speed_radps: float) -> float:
        """Advance dt [s]; return the drive torque at the driven wheels [N·m], + = forward.

        clutch: pedal 0 (released, engaged) .. 1 (pressed); ignored in automatic mode.
        """
        if self.automatic:
            clutch = 0.0
            self._auto_shift(dt, throttle, wheel_speed_radps)
        ratio = self.ratio()
        if self._shift_timer_s > 0.0:
            self._shift_timer_s -= dt
            clutch = 1.0
        gearbox_rpm = abs(wheel_speed_radps * ratio) * RADPS_TO_RPM
        if ratio == 0.0 or clutch >= 1.0:
            return self._free_rev(dt, throttle)
        return self._coupled(dt, throttle, 1.0 - clutch, ratio, gearbox_rpm)

    def _free_rev(self, dt: float, throttle: float) -> float:
        engine = self.engine
        target = engine.idle_rpm + throttle * (engine.redline_rpm - engine.idle_rpm)
        self.rpm += (target - self.rpm) * min(1.0, dt / FREE_REV_TAU_S)
        self.engine_torque_nm = engine.torque(self.rpm, throttle)
        self.reflected_inertia_kgm2 = 0.0
        return 0.0

    def _coupled(
        self, dt: float, throttle: float, engagement: float, ratio: float, gearbox_rpm: float
    ) -> float:
        engine = self.engine
        launch = engine.idle_rpm + throttle * (self.params.launch_rpm - engine.idle_rpm)
        if gearbox_rpm < launch:
            # Slipping: the engine runs at the launch speed and can only push, never pull.
            self.rpm += (launch - self.rpm) * min(1.0, dt / FREE_REV_TAU_S)
            torque = max(0.0, engine.torque(self.rpm, throttle))
            self.reflected_inertia_kgm2 = 0.0
        else:
            self.rpm = gearbox_rpm
            torque = engine.torque(gearbox_rpm, throttle)
            self.reflected_inertia_kgm2 = self.engine_inertia_kgm2 * ratio * ratio * engagement
        self.engine_torque_nm = torque
        return torque * engagement * ratio * self.params.efficiency

    def _auto_shift(self, dt: float, throttle: float, wheel_speed_radps: float) -> None:
        self._cooldown_s = max(0.0, self._cooldown_s - dt)
        if self.gear < 1 or self._shift_timer_s > 0.0 or self._cooldown_s > 0.0:
            return
        params = self.params
        wheel_rpm = abs(wheel_speed_radps) * RADPS_TO_RPM * params.final_drive
        rpm = wheel_rpm * params.ratios[self.gear - 1]
        up = params.upshift_rpm[0] + throttle * (params.upshift_rpm[1] - params.upshift_rpm[0])
        down = params.downshift_rpm[0] + throttle * (
            params.downshift_rpm[1] - params.downshift_rpm[0]
        )
        if rpm > up and self.gear < self._n:
            self._auto_engage(self.gear + 1)
        elif rpm < down and self.gear > 1:
            lower_rpm = wheel_rpm * params.ratios[self.gear - 2]
            if lower_rpm < self.engine.redline_rpm * 0.95:
                self._auto_engage(self.gear - 1)

    def _auto_engage(self, gear: int) -> None:
        self._engage(gear, self.params.shift_time_s)
        # Two shift times before the next decision: the schedule's hysteresis covers the
        # rpm jump, this covers the torque dip during the shift itself.
        self._cooldown_s = 2.0 * self.params.shift_time_s
