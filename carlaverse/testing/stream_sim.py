"""The pose stream of one actor through an emulated link into every renderer, in-process.

Deterministic and seeded: a sender samples a `Trajectory` at `rate_hz`, each sample goes
through the real wire codec (f32 position, f16 acceleration) and a `LinkModel` (delay, jitter,
loss as TCP or datagrams see it), and arrives at the receiver at the scheduled session time;
the receiver draws at `frame_hz` through a `RendererSet` (the library's world view in both
render modes, plus naive). Clocks are perfect here — the live runs include clock sync — so
the figures isolate what the renderers make of the stream.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from carlaverse import messages as m
from carlaverse.testing.linkemu import LinkModel, LinkProfile, Transport
from carlaverse.testing.render_metrics import RENDERERS, Frame, Metrics, RendererSet, measure
from carlaverse.testing.trajectories import Trajectory
from carlaverse.world.remote_actor import InterpolationSettings


@dataclass(frozen=True, slots=True)
class SimRun:
    duration_s: float = 20.0  # [s] of motion
    warmup_s: float = 3.0  # [s] not measured: delays and blends settle
    rate_hz: float = 50.0  # pose rate
    frame_hz: float = 100.0  # render rate


def simulate(
    trajectory: Trajectory,
    profile: LinkProfile,
    transport: Transport = "tcp",
    seed: int = 0,
    run: SimRun = SimRun(),
    settings: InterpolationSettings | None = None,
) -> tuple[dict[str, Metrics], int]:
    """Metrics per renderer, and how many samples the link lost (or retransmitted)."""
    rng = random.Random(seed)
    link = LinkModel(profile, random.Random(rng.random()), transport)
    arrivals = []
    for k in range(int(run.duration_s * run.rate_hz)):
        sent = k / run.rate_hz
        due = link.schedule(sent)
        if due is not None:
            wire = m.encode_pose(trajectory.pose_at(sent, seq=k))
            arrivals.append((due, k, m.POSE.decode(wire)))
    arrivals.sort()
    renderers = RendererSet("actor", settings or InterpolationSettings())
    frames: dict[str, list[Frame]] = {r: [] for r in RENDERERS}
    phase = rng.random() / run.frame_hz  # frames are not aligned with sends
    j = 0
    for k in range(int(run.duration_s * run.frame_hz)):
        now = phase + k / run.frame_hz
        while j < len(arrivals) and arrivals[j][0] <= now:
            renderers.add(arrivals[j][2], arrivals[j][0])
            j += 1
        if now < run.warmup_s:
            renderers.frame(now)
            continue
        for name, frame in renderers.frame(now).items():
            frames[name].append(frame)
    return {r: measure(frames[r], trajectory.xy) for r in RENDERERS}, link.lost
