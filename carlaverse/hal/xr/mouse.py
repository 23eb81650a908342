"""Desktop mode without a headset: mouse look through pygame, a head that turns and nods.

    xr:
      backend: mouse
      options: {degrees_per_pixel: 0.15, eye_height_m: 1.65}

Mouse motion (pygame MOUSEMOTION events, relative pixels) turns the head: right turns right,
up looks up; pitch stops at ±`max_pitch_deg`. Motion events reach only a focused window, so
this needs the node's pygame window, or, in tests, SDL's dummy video driver and posted events
(like the keyboard input). Only MOUSEMOTION events are consumed, so a keyboard device in the
same process still sees its keys. Walking comes from a keyboard or gamepad (`input:`).
"""

from __future__ import annotations

import math
import time
from typing import Annotated

import msgspec
import pygame

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.xr import XrHeadset
from carlaverse.hal.xr.sim import yaw_pitch_quaternion
from carlaverse.support.angles import wrap_angle


class MouseLookOptions(StrictStruct):
    degrees_per_pixel: Annotated[float, msgspec.Meta(gt=0, le=10)] = 0.15  # [deg/px]
    invert_y: bool = False
    max_pitch_deg: Annotated[float, msgspec.Meta(ge=0, le=89)] = 80.0  # [deg]
    eye_height_m: Annotated[float, msgspec.Meta(ge=0)] = 1.65  # [m] standing


class MouseLook(XrHeadset):
    Options = MouseLookOptions

    def __init__(self, options: MouseLookOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        try:
            if not pygame.display.get_init():
                pygame.display.init()
        except pygame.error as exc:
            raise DeviceError(f"mouse look needs SDL video ({exc})") from exc
        self.yaw = 0.0  # [rad] left positive
        self.pitch = 0.0  # [rad] up positive

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        o = self.options
        step = math.radians(o.degrees_per_pixel)
        for event in pygame.event.get(pygame.MOUSEMOTION):
            dx, dy = event.rel
            self.yaw -= dx * step  # moving right turns right (negative yaw)
            self.pitch += (dy if o.invert_y else -dy) * step  # screen y grows downwards
        limit = math.radians(o.max_pitch_deg)
        self.pitch = max(-limit, min(limit, self.pitch))
        self.yaw = wrap_angle(self.yaw)
        return (0.0, o.eye_height_m, 0.0), yaw_pitch_quaternion(self.yaw, self.pitch), True
