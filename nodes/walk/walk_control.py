"""One tick of the walker: head and controllers in, the walker in the world out.

The headset's head pose is in the stage (the tracked room); the stage stands in the world where
locomotion has moved it (`gait.Walker`). The head walks about the stage one to one; the
thumbstick (plus a keyboard's or gamepad's `move_x`/`move_y`, desktop mode) moves the stage
along the head's world yaw or the moving hand's; with lanes snapping on, a step off every
walkable lane is pulled back. Pure of processes and clocks: `loop_process` paces it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse_nodes.walk.config import WalkNodeConfig
from carlaverse_nodes.walk.gait import Walker
from carlaverse_nodes.walk.walkable import Walkable

from carlaverse.hal.input import InputDevice
from carlaverse.hal.xr import XrActions, XrHeadset
from carlaverse.hal.xr.frames import StageAnchor, WorldHead, openxr_to_world


@dataclass(frozen=True, slots=True)
class WalkOutput:
    head: WorldHead  # the head in the world [m, rad]
    vx: float  # [m/s] locomotion
    vy: float
    ax: float  # [m/s²]
    ay: float
    running_pace: bool
    interact: bool
    tracked: bool
    snapped: bool  # pulled back onto walkable ground this tick

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.vx, self.vy)


def merge_actions(actions: XrActions, device: InputDevice | None) -> XrActions:
    """The controllers' actions plus a keyboard's or gamepad's (sums clipped to the stick)."""
    if device is None:
        return actions
    state = device.poll()
    x = actions.move[0] + state.axes.get("move_x", 0.0)
    y = actions.move[1] + state.axes.get("move_y", 0.0)
    norm = max(1.0, math.hypot(x, y))
    return XrActions(
        (x / norm, y / norm), actions.run or state.buttons.get("run", False),
        actions.interact or state.buttons.get("interact", False), actions.hand_yaw,
    )  # fmt: skip


class WalkControl:
    def __init__(self, config: WalkNodeConfig, headset: XrHeadset,
                 device: InputDevice | None = None) -> None:  # fmt: skip
        self.config = config
        self.headset = headset
        self.device = device
        self.walker = Walker()
        self.walkable: Walkable | None = None
        self.snaps = 0

    def place(self, x: float, y: float, yaw: float) -> None:
        """Stand the stage's origin at (x, y) [m], its forward along `yaw` [rad]."""
        self.walker.place(x, y, yaw)

    def tick(self, dt_s: float) -> WalkOutput:
        pose = self.headset.pose()
        actions = merge_actions(self.headset.actions(), self.device)
        head = self._head(pose.position, pose.orientation)
        w, gait = self.walker, self.config.gait
        heading = head.yaw
        if gait.direction == "controller" and actions.hand_yaw is not None:
            heading = w.stage_yaw + actions.hand_yaw
        w.step(gait, actions.move, actions.run, heading, dt_s)
        head = self._head(pose.position, pose.orientation)
        snapped = self._keep_on_walkable(head)
        if snapped:
            head = self._head(pose.position, pose.orientation)
        return WalkOutput(head, w.vx, w.vy, w.ax, w.ay, actions.run, actions.interact,
                          pose.tracked, snapped)  # fmt: skip

    def _head(self, position: tuple, orientation: tuple) -> WorldHead:
        w = self.walker
        return openxr_to_world(position, orientation, StageAnchor(w.x, w.y, w.stage_yaw))

    def _keep_on_walkable(self, head: WorldHead) -> bool:
        if self.walkable is None or not self.config.lanes.snap:
            return False
        x, y = self.walkable.constrain(head.x, head.y)
        dx, dy = x - head.x, y - head.y
        if dx == 0.0 and dy == 0.0:
            return False
        self.walker.shift(dx, dy)
        n = math.hypot(dx, dy)  # stop walking into the edge; keep sliding along it
        into = -(self.walker.vx * dx + self.walker.vy * dy) / n
        if into > 0:
            self.walker.vx += into * dx / n
            self.walker.vy += into * dy / n
        self.snaps += 1
        return True
