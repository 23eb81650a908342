"""Time profiles for scripted devices: keyframes interpolated linearly, buttons held."""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct

NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class Keyframe(StrictStruct):
    """Channel values at time `t` after the device opened."""

    t: NonNegative  # [s]
    axes: dict[str, float] = msgspec.field(default_factory=dict)
    buttons: dict[str, bool] = msgspec.field(default_factory=dict)


def profile_time(keyframes: Sequence[Keyframe], t: float, loop: bool) -> float:
    """`t` folded into the profile's span when it loops."""
    end = keyframes[-1].t if keyframes else 0.0
    return t % end if loop and end > 0 else t


def sample_axis(keyframes: Sequence[Keyframe], name: str, t: float) -> float:
    """Linear interpolation between the keyframes that set `name`; held beyond the ends."""
    points = [(k.t, k.axes[name]) for k in keyframes if name in k.axes]
    if not points:
        return 0.0
    times = [p[0] for p in points]
    i = bisect.bisect_right(times, t)
    if i == 0:
        return points[0][1]
    if i == len(points):
        return points[-1][1]
    (t0, v0), (t1, v1) = points[i - 1], points[i]
    return v0 if t1 == t0 else v0 + (v1 - v0) * (t - t0) / (t1 - t0)


def sample_button(keyframes: Sequence[Keyframe], name: str, t: float) -> bool:
    """The value set by the last keyframe at or before `t` that mentions `name`."""
    state = False
    for keyframe in keyframes:
        if keyframe.t > t:
            break
        state = keyframe.buttons.get(name, state)
    return state
