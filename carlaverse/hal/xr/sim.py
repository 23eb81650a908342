"""A simulated participant: seated (looks left and right, nods) or standing (a walker whose
controllers follow a script). The head sways by seeded mean-reverting noise. Deterministic
given seed and clock.

    xr:
      backend: sim
      options:
        posture: standing                  # eye height 1.65 m instead of 1.2 m
        yaw_amplitude_rad: 0               # no looking around: the script steers
        script:                            # keyframes after the device opened
          - {t: 0, axes: {move_y: 0.0}}
          - {t: 1, axes: {move_y: 1.0, head_yaw_deg: 0}, buttons: {run: false}}
          - {t: 6, axes: {move_y: 1.0, head_yaw_deg: 90}}
        display: [640, 640]                # takes the view's rendered eyes, like a headset

Script channels: axes `move_x`, `move_y` (the thumbstick, -1..1), `head_yaw_deg`,
`head_pitch_deg` (added to the looking-around motion; yaw left positive, pitch up positive),
`hand_yaw_deg` (where the moving hand points in the stage, left positive; the hand is
tracked once the script names it); buttons `run`, `interact`. Axes are interpolated
linearly, buttons held (hal/input/profile).
"""

from __future__ import annotations

import math
import time
from typing import Annotated, Literal

import msgspec
import numpy as np

from carlaverse.config import ConfigError, StrictStruct
from carlaverse.fov import EyeAngles, EyeFov
from carlaverse.hal.device import Clock
from carlaverse.hal.input.profile import Keyframe, profile_time, sample_axis, sample_button
from carlaverse.hal.noise import OrnsteinUhlenbeck
from carlaverse.hal.xr import XrActions, XrHeadset
from carlaverse.hal.xr.eye_images import EyeFrame

NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Positive = Annotated[float, msgspec.Meta(gt=0)]
Pixels = Annotated[int, msgspec.Meta(ge=16, le=8192)]

SCRIPT_AXES = ("move_x", "move_y", "head_yaw_deg", "head_pitch_deg", "hand_yaw_deg")
SCRIPT_BUTTONS = ("run", "interact")
EYE_HEIGHT_M = {"seated": 1.2, "standing": 1.65}  # [m] above the stage floor


class SimEyes(StrictStruct):
    left: EyeAngles
    right: EyeAngles


class SimHeadsetOptions(StrictStruct):
    seed: int = 0
    posture: Literal["seated", "standing"] = "seated"
    eye_height_m: NonNegative | None = None  # [m] default from the posture
    yaw_amplitude_rad: NonNegative = 0.4  # [rad] look left/right
    yaw_period_s: Positive = 6.0  # [s]
    pitch_amplitude_rad: NonNegative = 0.05  # [rad] nod
    pitch_period_s: Positive = 2.3  # [s]
    sway_m: NonNegative = 0.01  # [m] typical head translation
    step_s: Positive = 0.01  # [s] noise time grid
    script: list[Keyframe] = msgspec.field(default_factory=list)
    loop: bool = False  # repeat the script from its last keyframe's time
    eyes: SimEyes | None = None  # the eyes' fields of view it reports, like a runtime
    # [width, height] px of each eye's display: the headset then takes the rendered eyes
    # (`present`) and reports what it was shown, as a runtime's compositor would receive them
    display: tuple[Pixels, Pixels] | None = None


def check_script(script: list[Keyframe]) -> None:
    where = "xr.options (backend 'sim')"
    for i, keyframe in enumerate(script):
        axes = set(keyframe.axes) - set(SCRIPT_AXES)
        unknown = sorted(axes | (set(keyframe.buttons) - set(SCRIPT_BUTTONS)))
        if unknown:
            known = f"axes {list(SCRIPT_AXES)} and buttons {list(SCRIPT_BUTTONS)}"
            raise ConfigError(where, f"script[{i}] names {unknown}; the channels are {known}")
    if [k.t for k in script] != sorted(k.t for k in script):
        raise ConfigError(where, "script keyframes must be in increasing t")


def yaw_pitch_quaternion(yaw: float, pitch: float) -> tuple[float, float, float, float]:
    """(w, x, y, z) for yaw about +y, then pitch about the head's +x."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    return (cy * cp, cy * sp, sy * cp, -sy * sp)


class SimHeadset(XrHeadset):
    Options = SimHeadsetOptions

    def __init__(self, options: SimHeadsetOptions, *, clock: Clock = time.monotonic) -> None:
        check_script(options.script)
        super().__init__(options, clock=clock)
        self.t0 = clock()
        self.noise = OrnsteinUhlenbeck(options.seed, 3, options.step_s, 1.0, 1.0)
        self.frames_shown = self.last_frame = 0  # the display's side (`present`)
        self.eye_means: tuple[float, ...] = ()  # [0..255] mean level of each eye last shown
        self.eyes_differ = False
        self.eye_height_m = (
            options.eye_height_m if options.eye_height_m is not None
            else EYE_HEIGHT_M[options.posture]
        )  # fmt: skip

    def _script_t(self, now: float) -> float:
        return profile_time(self.options.script, now - self.t0, self.options.loop)

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        o = self.options
        t = now - self.t0
        sway = o.sway_m * math.sqrt(2) * self.noise.at(t)  # OU(σ=1, θ=1) has std 1/√2
        position = (float(sway[0]), self.eye_height_m + float(sway[1]), float(sway[2]))
        st = self._script_t(now)
        yaw = o.yaw_amplitude_rad * math.sin(2 * math.pi * t / o.yaw_period_s)
        yaw += math.radians(sample_axis(o.script, "head_yaw_deg", st))
        pitch = o.pitch_amplitude_rad * math.sin(2 * math.pi * t / o.pitch_period_s)
        pitch += math.radians(sample_axis(o.script, "head_pitch_deg", st))
        return position, yaw_pitch_quaternion(yaw, pitch), True

    def display_size(self) -> tuple[int, int] | None:
        size = self.options.display
        return None if size is None else (int(size[0]), int(size[1]))

    def present(self, eyes: EyeFrame) -> None:
        """Take the frame as the display would: count it, note what the eyes saw."""
        self.frames_shown += 1
        self.last_frame = eyes.frame
        self.eye_means = tuple(float(image.mean()) for image in (eyes.left, eyes.right))
        self.eyes_differ = not np.array_equal(eyes.left, eyes.right)

    def eye_fovs(self) -> tuple[EyeFov, EyeFov] | None:
        eyes = self.options.eyes
        return None if eyes is None else (eyes.left.fov(), eyes.right.fov())

    def _actions(self, now: float) -> XrActions:
        script, st = self.options.script, self._script_t(now)
        move = (sample_axis(script, "move_x", st), sample_axis(script, "move_y", st))
        hand = None
        if any("hand_yaw_deg" in k.axes for k in script):
            hand = math.radians(sample_axis(script, "hand_yaw_deg", st))
        return XrActions(move, sample_button(script, "run", st),
                         sample_button(script, "interact", st), hand)  # fmt: skip
