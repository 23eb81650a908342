"""The `sim` input: a scripted driver or rider, honest and deterministic.

Three modes, chosen by `mode`:
- `profile`: channels follow keyframes (axes interpolated linearly, buttons held);
- `random_walk`: each axis is seeded mean-reverting noise around its mean (a stress driver);
- `path`: a pure-pursuit driver steers along waypoints and holds a target speed; the node
  feeds it the vehicle state with `observe()` each tick, so the node's own physics stays in
  the loop, as with a human. A node may hand it another route (`follow`: one it planned
  along the map's lanes) or have it wait, braking, for one (`hold`).
Given the same options, seed and clock readings, the output is identical.

    input:
      backend: sim
      options:
        axes: [steer, throttle, brake]
        mode: profile
        profile:
          - {t: 0, axes: {throttle: 0.0}}
          - {t: 2, axes: {throttle: 0.6, steer: 0.1}}
"""

from __future__ import annotations

import time
from typing import Annotated, Literal

import msgspec

from carlaverse.config import ConfigError, StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.input import Axes, Buttons, Hats, InputDevice
from carlaverse.hal.input.profile import Keyframe, profile_time, sample_axis, sample_button
from carlaverse.hal.input.pursuit import PathFollow, PurePursuit, VehicleState
from carlaverse.hal.noise import OrnsteinUhlenbeck

UNIPOLAR_DEFAULT = ["throttle", "brake", "clutch", "cadence"]


class RandomWalk(StrictStruct):
    seed: int = 0
    step_s: Annotated[float, msgspec.Meta(gt=0)] = 0.02  # [s] noise time grid
    sigma: Annotated[float, msgspec.Meta(ge=0)] = 0.3  # [1/√s] noise strength
    reversion_per_s: Annotated[float, msgspec.Meta(ge=0)] = 1.0  # [1/s] pull to the mean
    mean: dict[str, float] = msgspec.field(default_factory=dict)


class SimInputOptions(StrictStruct):
    axes: list[str] = msgspec.field(default_factory=lambda: ["steer", "throttle", "brake"])
    buttons: list[str] = msgspec.field(default_factory=list)
    unipolar: list[str] = msgspec.field(default_factory=lambda: list(UNIPOLAR_DEFAULT))
    mode: Literal["profile", "random_walk", "path"] = "profile"
    profile: list[Keyframe] = msgspec.field(default_factory=list)
    loop: bool = False  # repeat the profile from its last keyframe's time
    random_walk: RandomWalk = msgspec.field(default_factory=RandomWalk)
    path: PathFollow | None = None


def check_options(options: SimInputOptions) -> None:
    """Cross-field checks msgspec cannot express; ConfigError names the offending entry."""
    where = "input.options (backend 'sim')"
    if options.mode == "path" and options.path is None:
        raise ConfigError(where, "mode 'path' needs a `path:` block with waypoints")
    path = options.path
    if path is not None and path.loop_from is not None and path.loop_from >= len(path.waypoints):
        raise ConfigError(
            where, f"path.loop_from {path.loop_from} is past the last of the "
            f"{len(path.waypoints)} waypoints (the first is 0)",
        )  # fmt: skip
    for i, keyframe in enumerate(options.profile):
        unknown = (set(keyframe.axes) - set(options.axes)) | (
            set(keyframe.buttons) - set(options.buttons)
        )
        if unknown:
            raise ConfigError(
                where, f"profile[{i}] names channels {sorted(unknown)} not in axes/buttons"
            )
    if [k.t for k in options.profile] != sorted(k.t for k in options.profile):
        raise ConfigError(where, "profile keyframes must be in increasing t")


class SimInput(InputDevice):
    """A scripted device; see the module docstring for its modes."""

    Options = SimInputOptions

    def __init__(self, options: SimInputOptions, *, clock: Clock = time.monotonic) -> None:
        check_options(options)
        super().__init__(options, clock=clock)
        self.t0 = clock()  # [s] profile and noise time starts here
        walk = options.random_walk
        means = [walk.mean.get(name, 0.0) for name in options.axes]
        self.noise = OrnsteinUhlenbeck(
            walk.seed, len(options.axes), walk.step_s, walk.sigma, walk.reversion_per_s, means
        )
        self.driver = PurePursuit(options.path) if options.path else None
        self.vehicle: VehicleState | None = None
        self.holding = False  # braking until `follow` hands a route

    def follow(
        self, waypoints: list[tuple[float, float]] | None, loop_from: int | None = None
    ) -> None:
        """Drive `waypoints` [m] from now (after the last, go on at `loop_from`); None: the
        configured path again. Only a `path` driver takes a route; other modes ignore it."""
        self.holding = False
        path = self.options.path
        if path is None or self.options.mode != "path":
            return
        if waypoints is not None:
            path = msgspec.structs.replace(path, waypoints=waypoints, loop_from=loop_from)
        self.driver = PurePursuit(path)

    def hold(self) -> None:
        """Brake, wheel straight, until `follow` (the node is fetching the route)."""
        self.holding = True

    def observe(self, x: float, y: float, yaw: float, speed: float) -> None:
        """Tell the path driver where the vehicle is [m, m, rad, m/s]."""
        self.vehicle = VehicleState(x, y, yaw, speed)

    def _poll(self, now: float) -> tuple[Axes, Buttons, Hats]:
        t = now - self.t0
        if self.options.mode == "profile":
            raw = self._profile(t)
        elif self.options.mode == "random_walk":
            raw = self._walk(t)
        else:
            raw = self._path()
        axes = {name: self._range(name, raw.get(name, 0.0)) for name in self.options.axes}
        return axes, self._buttons(t), {}

    def _profile(self, t: float) -> Axes:
        t = profile_time(self.options.profile, t, self.options.loop)
        return {name: sample_axis(self.options.profile, name, t) for name in self.options.axes}

    def _walk(self, t: float) -> Axes:
        return dict(zip(self.options.axes, self.noise.at(t).tolist(), strict=True))

    def _path(self) -> Axes:
        if self.holding and self.driver is not None:
            return {self.driver.path.brake_axis: 1.0}
        if self.driver is None or self.vehicle is None:
            return {}  # no state yet: hands off, feet off
        return self.driver.controls(self.vehicle)

    def _buttons(self, t: float) -> Buttons:
        t = profile_time(self.options.profile, t, self.options.loop)
        return {name: sample_button(self.options.profile, name, t) for name in self.options.buttons}

    def _range(self, name: str, value: float) -> float:
        low = 0.0 if name in self.options.unipolar else -1.0
        return min(1.0, max(low, value))
