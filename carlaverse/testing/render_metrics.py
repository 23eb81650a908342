"""Every renderer measured against the same references (issue 11, item 3).

A `RendererSet` takes one actor's pose stream (a synthetic feed: each pose goes into the world
views' intakes as it would travel, its 64 bytes) and draws it three ways per frame:
- `past`: the library's world view in past mode (interpolated, now − delay);
- `present`: the library's world view in present mode (projected to now, blended);
- `naive`: the newest sample received, drawn as is.

Each frame is recorded as (now, time shown, x, y). `measure()` turns frames into the same four
figures for every renderer, given the true path:
- error vs the truth at the time shown: is the drawing right about the moment it claims?
- error vs the truth now: what a human sees — where the actor is drawn vs where it is;
- lag: now − time shown (0 for present, the delay for past, the sample's age for naive);
- smoothness: the largest frame-to-frame jump beyond the true motion over that frame,
  |Δshown − Δtruth(now)|: a renderer that freezes and leaps scores what a viewer would see.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import msgspec

from carlaverse.messages import Pose, encode_pose
from carlaverse.support.stats import percentile
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView

RENDERERS = ("past", "present", "naive")
Frame = tuple[float, float, float, float]  # now, time shown [s], x, y [m]
Truth = Callable[[float], tuple[float, float]]  # session time -> true x, y [m]


class RendererSet:
    """One actor's stream through every renderer. Feed with `add`, draw with `frame`."""

    def __init__(self, actor_id: str, settings: InterpolationSettings) -> None:
        self.actor_id = actor_id
        self.views = {
            mode: WorldView("probe", msgspec.structs.replace(settings, render_mode=mode))
            for mode in ("past", "present")
        }
        for view in self.views.values():
            view.intake.present(actor_id)
        self.newest: Pose | None = None

    def add(self, pose: Pose, rx_t: float) -> None:
        wire = encode_pose(pose)
        for view in self.views.values():
            view.intake.pose(self.actor_id, wire, rx_t)
        if self.newest is None or pose.t > self.newest.t:
            self.newest = pose

    def frame(self, now: float) -> dict[str, Frame]:
        """What each renderer draws at session time `now` (renderers with nothing yet omitted)."""
        out: dict[str, Frame] = {}
        for mode, view in self.views.items():
            view.update(now)
            for v in view.ego_views(now):
                out[mode] = (now, v.render_t, v.x, v.y)
        if self.newest is not None:
            out["naive"] = (now, self.newest.t, self.newest.x, self.newest.y)
        return out

    @property
    def delay_s(self) -> float:
        return self.views["past"].delay_s


@dataclass(frozen=True, slots=True)
class Metrics:
    frames: int
    shown_p95_m: float  # error vs truth at the time shown
    shown_max_m: float
    now_p50_m: float  # error vs truth now
    now_p95_m: float
    now_max_m: float
    lag_mean_ms: float
    jump_max_m: float  # largest frame-to-frame jump beyond the true motion

    def row(self) -> dict[str, float]:
        return dataclasses.asdict(self)


def measure(frames: Sequence[Frame], truth: Truth) -> Metrics:
    """The four figures of one renderer over consecutive `frames` of one actor."""
    shown_err, now_err, lags, jumps = [], [], [], []
    previous: tuple[float, float, float, float] | None = None  # x, y, true x, true y (now)
    for now, shown_t, x, y in frames:
        ts, tn = truth(shown_t), truth(now)
        shown_err.append(math.hypot(x - ts[0], y - ts[1]))
        now_err.append(math.hypot(x - tn[0], y - tn[1]))
        lags.append(now - shown_t)
        if previous is not None:
            px, py, ptx, pty = previous
            jumps.append(math.hypot((x - px) - (tn[0] - ptx), (y - py) - (tn[1] - pty)))
        previous = (x, y, tn[0], tn[1])
    return Metrics(
        frames=len(frames),
        shown_p95_m=percentile(shown_err, 0.95),
        shown_max_m=max(shown_err, default=math.nan),
        now_p50_m=percentile(now_err, 0.5),
        now_p95_m=percentile(now_err, 0.95),
        now_max_m=max(now_err, default=math.nan),
        lag_mean_ms=1e3 * sum(lags) / len(lags) if lags else math.nan,
        jump_max_m=max(jumps, default=math.nan),
    )


# ---------------------------------------------------------------- reports of tools/wan/wan_probe.py


class HasPoseAt(Protocol):
    def pose_at(self, t: float) -> Pose: ...


def window(report: dict[str, Any], target: str, start: float, end: float) -> list[list[Any]]:
    """A probe report's rows of `target` taken between monotonic times `start` and `end`."""
    return [r for r in report["samples"] if r[1] == target and start <= r[0] <= end]


def probe_metrics(rows: list[list[Any]], path: HasPoseAt) -> dict[str, Metrics]:
    """Every renderer's figures over probe `rows` (see `window`), against the true `path`."""

    def truth(t: float) -> tuple[float, float]:
        p = path.pose_at(t)
        return p.x, p.y

    frames = {r: [tuple(row[3][r]) for row in rows if r in row[3]] for r in RENDERERS}
    return {r: measure(frames[r], truth) for r in RENDERERS}
