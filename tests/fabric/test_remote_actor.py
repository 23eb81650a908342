"""Interpolation, extrapolation and despawn, driven entirely by hand-set times."""

from __future__ import annotations

import math
import random

import msgspec
import pytest

from carlaverse.fabric.remote_actor import InterpolationSettings, Phase, RemoteActor
from carlaverse.fabric.world_view import WorldView
from carlaverse.messages import POSE_FLAG_TELEPORT, Pose
from carlaverse.paths import CirclePath, PolylinePath

CIRCLE = CirclePath(radius=30.0, speed_mps=14.0)
S = InterpolationSettings()


def feed(actor: RemoteActor, path, arrivals):  # type: ignore[no-untyped-def]
    for rx, t in sorted(arrivals):
        actor.add(path.pose_at(t), rx)


def run_stream(
    path,
    latency: float,
    jitter: float,
    loss: float,
    seed: int = 3,
    settings: InterpolationSettings = S,
    rate_hz: float = 50.0,
):  # type: ignore[no-untyped-def]
    """Send at rate_hz for 10 s through a lossy, jittery link; render at 100 Hz; errors."""
    rnd = random.Random(seed)
    actor = RemoteActor("a", settings)
    sends = [k / rate_hz for k in range(int(10 * rate_hz))]
    arrivals = sorted(
        (t + latency + rnd.uniform(-jitter, jitter), t) for t in sends if rnd.random() >= loss
    )
    errors, j = [], 0
    for step in range(1000):
        now = step * 0.01
        while j < len(arrivals) and arrivals[j][0] <= now:
            actor.add(path.pose_at(arrivals[j][1]), arrivals[j][0])
            j += 1
        view = actor.view(now)
        if view is not None and now > 2.0:  # after the delay estimate settles
            true = path.pose_at(view.render_t)
            errors.append(math.hypot(view.x - true.x, view.y - true.y))
    errors.sort()
    return errors, actor


def p95(values: list[float]) -> float:
    return values[int(0.95 * (len(values) - 1))]


def test_clean_stream_interpolates_a_circle_exactly() -> None:
    errors, actor = run_stream(CIRCLE, 0.0005, 0.0002, 0.0)
    assert errors[-1] < 1e-3  # Hermite with sampled velocities is near-exact on a circle
    assert actor.delay_s < 2.5 * 0.02  # adapted down from the 2-interval start


def test_jitter_and_loss_stay_within_ten_centimetres() -> None:
    errors, actor = run_stream(CIRCLE, 0.030, 0.010, 0.05)
    assert p95(errors) <= 0.10
    # the delay grew to cover latency + jitter, within the clamp
    assert 0.05 < actor.delay_s <= S.max_delay_s


def test_corners_are_smoothed_not_teleported() -> None:
    square = PolylinePath(points=[(0, 0), (40, 0), (40, 40), (0, 40)], speed_mps=14.0)
    errors, actor = run_stream(square, 0.02, 0.005, 0.02)
    # velocity jumps at corners: Hermite cuts them by a few cm, never a jump
    assert p95(errors) < 0.10 and errors[-1] < 0.5
    assert actor.snaps == 0


def test_delay_starts_at_two_intervals_and_is_clamped() -> None:
    actor = RemoteActor("a", S)
    assert actor.delay_s == pytest.approx(2 * S.initial_interval_s)
    slow = msgspec.structs.replace(S, max_delay_s=0.08, delay_slew=10.0)
    _, clamped = run_stream(CIRCLE, 0.2, 0.05, 0.0, settings=slow)
    assert clamped.delay_s == pytest.approx(0.08)


def test_late_samples_extrapolate_for_a_bounded_time_then_hold() -> None:
    actor = RemoteActor("a", S)
    line = PolylinePath(points=[(0, 0), (1000, 0)], speed_mps=10.0)
    for k in range(10):
        actor.add(line.pose_at(k * 0.02), k * 0.02)
    last_t = 9 * 0.02
    view = actor.view(last_t + actor.delay_s + 0.1)
    assert view.phase is Phase.EXTRAPOLATING and view.x == pytest.approx(
        10 * (last_t + 0.1), abs=1e-3
    )
    held = actor.view(last_t + actor.delay_s + 1.0)
    assert held.phase is Phase.HOLDING
    assert held.x == pytest.approx(10 * (last_t + S.max_extrapolation_s), abs=1e-2)


def test_small_correction_is_blended_large_is_snapped() -> None:
    actor = RemoteActor("a", msgspec.structs.replace(S, adaptive=False))
    line = PolylinePath(points=[(0, 0), (1000, 0)], speed_mps=10.0)
    for k in range(5):
        actor.add(line.pose_at(k * 0.02), k * 0.02)
    before = actor.view(0.2)  # extrapolating past t=0.08
    # a late sample says the actor is 0.5 m to the side: no jump, blended out
    actor.add(msgspec.structs.replace(line.pose_at(0.1), y=0.5), 0.2)
    after = actor.view(0.2)
    assert abs(after.y - before.y) < 1e-6
    assert actor.view(0.7).y == pytest.approx(0.5, abs=0.01)  # corrected after ~5 blend times
    # a 10 m error is a teleport, not a drift
    actor.add(msgspec.structs.replace(line.pose_at(0.72), y=10.5), 0.72)
    assert actor.view(0.9).y == pytest.approx(10.5, abs=0.05) and actor.snaps == 1


def test_teleport_flag_snaps() -> None:
    actor = RemoteActor("a", S)
    actor.add(Pose(1, 0.0, 0.0, 0.0), 0.0)
    actor.view(0.5)
    actor.add(Pose(2, 0.45, 3.0, 0.0, flags=POSE_FLAG_TELEPORT), 0.5)
    assert actor.snaps == 1


def test_yaw_takes_the_shortest_arc() -> None:
    actor = RemoteActor("a", msgspec.structs.replace(S, adaptive=False))
    actor.add(Pose(1, 0.0, 0, 0, yaw=math.pi - 0.1), 0.0)
    actor.add(Pose(2, 0.02, 0, 0, yaw=-math.pi + 0.1), 0.02)
    view = actor.view(0.01 + actor.delay_s)
    assert abs(abs(view.yaw) - math.pi) < 1e-6  # through ±π, not through 0


def test_stale_then_despawned_after_timeout() -> None:
    world = WorldView("me", S)
    world.push_present("a")
    world.push_pose("a", Pose(1, 0.0, 0, 0), 0.0)
    world.update(0.5)
    assert "a" in world.egos and not next(world.ego_views(0.5)).stale
    world.update(1.5)
    assert next(world.ego_views(1.5)).stale
    world.update(S.despawn_timeout_s + 0.01)
    assert "a" not in world.egos and world.despawns[-1].reason == "timeout"


def test_presence_loss_and_authority_event_despawn_at_once_and_tombstone() -> None:
    world = WorldView("me", S)
    for n in ("a", "b"):
        world.push_present(n)
        world.push_pose(n, Pose(1, 0.0, 0, 0), 0.0)
    world.update(0.1)
    world.push_gone("a", "liveliness", 0.1)
    world.push_gone("b", "timeout", 0.1)
    world.push_pose("a", Pose(2, 0.05, 0, 0), 0.12)  # in flight when it left: no ghost
    world.update(0.2)
    assert not world.egos
    world.push_present("a")  # it came back (re-join)
    world.push_pose("a", Pose(3, 1.0, 0, 0), 1.0)
    world.update(1.0)
    assert "a" in world.egos


def test_poses_from_nodes_without_presence_are_rejected() -> None:
    world = WorldView("me", S)
    world.push_pose("mallory", Pose(1, 0.0, 0, 0), 0.0)
    world.push_pose("me", Pose(1, 0.0, 0, 0), 0.0)  # our own echo
    world.update(0.0)
    assert not world.egos and world.rejected["pose_from_absent_node"] == 1
