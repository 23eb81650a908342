"""Interpolation, extrapolation and despawn, driven entirely by hand-set times."""

from __future__ import annotations

import itertools
import math
import random

import msgspec
import pytest
from carlaverse_nodes.scripted.trajectories import CirclePath, PolylinePath

from carlaverse.messages import POSE_FLAG_TELEPORT, Pose, encode_pose
from carlaverse.support.stats import percentile
from carlaverse.world.remote_actor import InterpolationSettings, Phase, RemoteActor
from carlaverse.world.world_view import WorldView

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


def test_clean_stream_interpolates_a_circle_exactly() -> None:
    errors, actor = run_stream(CIRCLE, 0.0005, 0.0002, 0.0)
    assert errors[-1] < 1e-3  # Hermite with sampled velocities is near-exact on a circle
    assert actor.delay_s < 2.5 * 0.02  # adapted down from the 2-interval start


def test_jitter_and_loss_stay_within_ten_centimetres() -> None:
    errors, actor = run_stream(CIRCLE, 0.030, 0.010, 0.05)
    assert percentile(errors, 0.95) <= 0.10
    # the delay grew to cover latency + jitter, within the clamp
    assert 0.05 < actor.delay_s <= S.max_delay_s


def test_corners_are_smoothed_not_teleported() -> None:
    square = PolylinePath(points=[(0, 0), (40, 0), (40, 40), (0, 40)], speed_mps=14.0)
    errors, actor = run_stream(square, 0.02, 0.005, 0.02)
    # velocity jumps at corners: Hermite cuts them by a few cm, never a jump
    assert percentile(errors, 0.95) < 0.10 and errors[-1] < 0.5
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


def test_a_sample_out_of_order_is_slotted_in_and_the_newest_stays_newest() -> None:
    line = PolylinePath(points=[(0, 0), (1000, 0)], speed_mps=10.0)
    actor = RemoteActor("a", msgspec.structs.replace(S, adaptive=False))
    for t, rx in ((0.00, 0.001), (0.04, 0.041), (0.02, 0.045), (0.04, 0.046), (0.06, 0.061)):
        actor.add(line.pose_at(t), rx)
    actor.add(line.pose_at(-0.02), 0.062)  # older than the whole buffer: nothing to slot into
    assert actor.samples_received == 4  # the duplicate and the too-old sample are not counted
    between = actor.past(0.03, 0.07)  # between the late 0.02 and 0.04: interpolated, exact
    assert between is not None and between.phase is Phase.INTERPOLATING
    assert between.x == pytest.approx(0.3, abs=1e-6)
    # present mode projects the newest sample (0.06), not the one that came last (0.02)
    assert actor.present(0.06).x == pytest.approx(0.6, abs=1e-6)
    assert actor.last_rx_t == 0.061  # a refused sample is not counted as the newest arrival


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
    world.intake.present("a")
    world.intake.pose("a", encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
    world.update(0.5)
    assert "a" in world.egos and not next(world.ego_views(0.5)).stale
    world.update(1.5)
    assert next(world.ego_views(1.5)).stale
    world.update(S.despawn_timeout_s + 0.01)
    assert "a" not in world.egos and world.despawns[-1].reason == "timeout"


def _hearing(*node_ids: str) -> WorldView:
    """A world view that has heard a first pose from each of `node_ids`, at 0.1 s."""
    world = WorldView("me", S)
    for n in node_ids:
        world.intake.present(n)
        world.intake.pose(n, encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
    world.update(0.1)
    return world


def test_presence_loss_and_authority_event_despawn_at_once_and_tombstone() -> None:
    world = _hearing("a", "b")
    world.intake.gone("a", "liveliness", 0.1)
    world.intake.gone("b", "timeout", 0.1)
    in_flight = encode_pose(Pose(2, 0.05, 0, 0))
    world.intake.pose("a", in_flight, 0.12)  # in flight when it left: no ghost
    world.update(0.2)
    assert not world.egos
    world.intake.present("a")  # it came back (re-join)
    world.intake.pose("a", encode_pose(Pose(3, 1.0, 0, 0)), 1.0)
    world.update(1.0)
    assert "a" in world.egos


def test_a_token_loss_heard_before_the_authoritys_left_is_amended_to_left() -> None:
    # The leaver's DELETE and the authority's `left` event reach a peer on different links.
    world = _hearing("a", "b")
    world.intake.gone("a", "liveliness", 0.1)
    world.intake.gone("b", "liveliness", 0.1)
    world.update(0.15)
    assert not world.egos
    world.intake.gone("a", "left", 0.2)  # the authority's word, late: a left on purpose
    world.update(0.2)
    assert [(d.actor_id, d.reason, d.t) for d in world.despawns] == [
        ("a", "left", 0.1), ("b", "liveliness", 0.1)
    ]  # fmt: skip
    world.intake.present("b")  # b re-joins and later leaves properly: one record each time
    world.intake.pose("b", encode_pose(Pose(2, 1.0, 0, 0)), 1.0)
    world.update(1.0)
    world.intake.gone("b", "left", 1.1)
    world.update(1.1)
    assert [d.reason for d in world.despawns] == ["left", "liveliness", "left"]


def test_poses_from_nodes_without_presence_are_rejected() -> None:
    world = WorldView("me", S)
    world.intake.pose("mallory", encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
    world.intake.pose("me", encode_pose(Pose(1, 0.0, 0, 0)), 0.0)  # our own echo
    world.update(0.0)
    assert not world.egos and world.rejected["pose_from_absent_node"] == 1


# ---------------------------------------------------------------- one render time per view

PAST = msgspec.structs.replace(S, render_mode="past")
PRESENT = msgspec.structs.replace(S, render_mode="present")


def parallel_world(settings: InterpolationSettings, far_latency: float) -> list[float]:
    """Two actors 3 m apart on concentric circles, one over a slow link: rendered gaps."""
    inner, outer = CirclePath(radius=20.0, speed_mps=14.0), CirclePath(radius=23.0, speed_mps=16.1)
    world = WorldView("me", settings)
    for n in ("near", "far"):
        world.intake.present(n)
    arrivals = sorted(
        [(k * 0.02 + 0.001, "near", k * 0.02) for k in range(300)]
        + [(k * 0.02 + far_latency, "far", k * 0.02) for k in range(300)]
    )
    gaps, j = [], 0
    for step in range(600):
        now = step * 0.01
        while j < len(arrivals) and arrivals[j][0] <= now:
            rx, node, t = arrivals[j]
            world.intake.pose(
                node, encode_pose((inner if node == "near" else outer).pose_at(t)), rx
            )
            j += 1
        world.update(now)
        views = {v.actor_id: v for v in world.ego_views(now)}
        if len(views) == 2 and now > 2.0:
            assert views["near"].render_t == views["far"].render_t
            gaps.append(math.dist((views["near"].x, views["near"].y),
                                  (views["far"].x, views["far"].y)))  # fmt: skip
    return gaps


@pytest.mark.parametrize("settings", [PAST, PRESENT], ids=["past", "present"])
def test_every_actor_of_a_view_is_drawn_at_one_time(settings: InterpolationSettings) -> None:
    gaps = parallel_world(settings, far_latency=0.060)
    assert len(gaps) > 300
    assert max(abs(g - 3.0) for g in gaps) < 0.01


def test_past_view_delay_covers_the_slowest_stream() -> None:
    world = WorldView("me", PAST)
    parallel_world(PAST, far_latency=0.060)
    world = WorldView("me", PAST)
    world.intake.present("a")
    for k in range(200):
        world.intake.pose("a", encode_pose(CIRCLE.pose_at(k * 0.02)), k * 0.02 + 0.06)
        world.update(k * 0.02 + 0.06)
        world.render_time(k * 0.02 + 0.06)
    assert 0.08 < world.delay_s < 0.12  # interval + latency + margin, reached by slewing


def test_present_mode_projects_to_now_and_blends_corrections() -> None:
    actor = RemoteActor("a", PRESENT)
    line = PolylinePath(points=[(0, 0), (1000, 0)], speed_mps=10.0)
    for k in range(5):
        actor.add(line.pose_at(k * 0.02), k * 0.02 + 0.05)
    view = actor.present(0.2)
    assert view.render_t == 0.2 and view.x == pytest.approx(2.0, abs=1e-6)
    # a sample 0.5 m to the side: blended in, continuous, done within the blend time
    actor.add(msgspec.structs.replace(line.pose_at(0.1), y=0.5), 0.2)
    ys = [actor.present(0.2 + k * 0.01).y for k in range(30)]
    spread = 0.5 * 0.01 / PRESENT.present_blend_s  # the correction spread over the frames
    assert max(abs(b - a) for a, b in itertools.pairwise(ys)) < 1.5 * spread
    assert ys[0] == pytest.approx(0.0, abs=1e-9) and ys[-1] == pytest.approx(0.5, abs=1e-9)
    actor.add(msgspec.structs.replace(line.pose_at(0.5), y=10.5), 0.5)
    assert actor.present(0.55).y == pytest.approx(10.5) and actor.snaps == 1


def test_present_mode_holds_after_the_projection_limit_and_never_reverses() -> None:
    actor = RemoteActor("a", PRESENT)
    braking = Pose(1, 0.0, 0.0, 0.0, vx=2.0, ax=-4.0)  # stops after 0.5 s, 0.5 m on
    actor.add(braking, 0.0)
    assert actor.present(0.45).x == pytest.approx(2.0 * 0.45 - 2.0 * 0.45**2)
    held = actor.present(2.0)
    assert held.phase is Phase.HOLDING and held.x == pytest.approx(0.5) and held.vx == 0.0


# ---------------------------------------------------------------- hostile input (issue 20)


def test_the_authority_id_never_becomes_an_actor() -> None:
    world = WorldView("me", S)
    world.intake.present("authority")
    world.intake.pose("authority", encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
    world.update(0.0)
    assert not world.egos and "authority" not in world.present
    assert world.rejected["reserved_id"] == 1 and world.rejected["pose_from_absent_node"] == 1


def test_pose_times_far_from_session_time_are_rejected() -> None:
    world = WorldView("me", S)
    world.intake.present("a")
    world.intake.pose("a", encode_pose(Pose(1, 100.0 + 3600, 0, 0)), 100.0)
    world.intake.pose("a", encode_pose(Pose(2, 100.0 - 6, 0, 0)), 100.0)
    world.update(100.0)
    assert not world.egos and world.rejected["pose_time_implausible"] == 2
    assert not world.stats  # nothing kept for a rejected sender


def test_statistics_only_for_present_senders_and_bounded() -> None:
    from carlaverse.world import world_view

    world = WorldView("me", S)
    for k in range(world_view.STATS_LIMIT + 50):
        node = f"n{k}"
        world.intake.present(node)
        world.intake.pose(node, encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
        world.intake.gone(node, "left", 0.0)
    world.intake.pose("ghost", encode_pose(Pose(1, 0.0, 0, 0)), 0.0)
    world.update(0.0)
    assert len(world.stats) <= world_view.STATS_LIMIT and "ghost" not in world.stats


# ---------------------------------------------------------------- NPCs as arrays


def npc_batch(t: float, ids: list[str], paths: dict[str, CirclePath]):  # type: ignore[no-untyped-def]
    import numpy as np

    from carlaverse.messages import NPC_DTYPE, NpcBatch

    rows = np.zeros(len(ids), dtype=NPC_DTYPE)
    for i, npc_id in enumerate(ids):
        p = paths[npc_id].pose_at(t)
        rows[i] = (p.x, p.y, 0.0, p.yaw, p.vx, p.vy, p.wz, 4.5, 1.8, 1.5, 0, 0, 0)
    return NpcBatch.pack(int(t * 20), t, ids, rows)


def test_npcs_interpolate_as_arrays_at_the_views_render_time() -> None:
    paths = {f"v{k}": CirclePath(radius=30.0 + k, speed_mps=10.0, phase_deg=7.0 * k)
             for k in range(20)}  # fmt: skip
    world = WorldView("me", PAST)
    errors = []
    for k in range(60):
        t = k * 0.05
        ids = sorted(paths) if k < 40 else sorted(paths)[5:]  # five NPCs leave at 2 s
        world.intake.npc(npc_batch(t, ids, paths), t + 0.01)
        for sub in range(5):
            now = t + 0.01 + sub * 0.01
            world.update(now)
            frame = world.npc_frame(now)
            assert frame is not None and frame.t == world.render_time(now)
            if now > 1.0:
                for i, npc_id in enumerate(frame.ids):
                    true = paths[npc_id].pose_at(frame.t)
                    errors.append(math.hypot(frame.x[i] - true.x, frame.y[i] - true.y))
    assert len(world.npcs) == 15 and "v0" not in world.npcs
    assert max(errors) < 0.01  # f32 rows, Hermite with sampled velocities
    views = list(world.npc_views(3.0))
    assert len(views) == 15 and views[0].render_t == world.render_time(3.0)
    assert set(world.npc_frame(3.0).kinds()) == {"car"}


def test_npcs_appearing_after_an_empty_batch_are_drawn_not_raised() -> None:
    """A town that starts empty, or a tile the NPCs have just entered: the view interpolates
    between a batch with no NPCs and one with some (the newcomers dead-reckoned back)."""
    paths = {f"v{k}": CirclePath(radius=30.0 + k, speed_mps=10.0) for k in range(3)}
    world = WorldView("me", PAST)
    for k in range(12):
        t = k * 0.05
        ids = [] if k < 6 else sorted(paths)
        world.intake.npc(npc_batch(t, ids, paths), t + 0.01)
    for now in (0.3, 0.31, 0.35, 0.4, 0.5, 0.6):  # render times across the empty -> full step
        world.update(now)
        frame = world.npc_frame(now)
        assert frame is not None
        for i, npc_id in enumerate(frame.ids):
            true = paths[npc_id].pose_at(frame.t)
            assert math.hypot(frame.x[i] - true.x, frame.y[i] - true.y) < 0.1, (now, npc_id)
    assert sorted(world.npcs) == sorted(paths)


def test_a_view_that_never_draws_keeps_a_bounded_buffer_and_still_draws_after() -> None:
    # A minute at 50 Hz with no render in between: without pruning on arrival, 3000 samples.
    actor = RemoteActor("a", S)
    keep_s = S.max_delay_s + S.history_s
    for k in range(3000):
        t = k / 50
        actor.add(CIRCLE.pose_at(t), t + 0.01)
    assert len(actor._t) <= 2 * keep_s * 50 + 1
    newest = 2999 / 50
    assert actor._t[-1] == newest and actor._t[0] >= newest - 2 * keep_s
    # The oldest time a past render may ask for (the longest delay) still interpolates.
    render_t = newest + 0.01 - S.max_delay_s
    view = actor.past(render_t, newest + 0.01)
    assert view is not None and view.phase is Phase.INTERPOLATING
    truth = CIRCLE.pose_at(render_t)
    assert math.hypot(view.x - truth.x, view.y - truth.y) < 0.05


def test_the_despawn_log_keeps_the_newest_within_its_bound(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # With interest areas every ego driving out of a node's tiles is a despawn (`far`): over
    # hours the log would grow without end.
    from carlaverse.world import world_view

    monkeypatch.setattr(world_view, "DESPAWN_LIMIT", 50)
    world = WorldView("me", S)
    for k in range(80):
        node_id, t = f"n{k}", k * 0.1
        world.intake.present(node_id)
        world.intake.pose(node_id, encode_pose(Pose(1, t, 0, 0)), t)
        world.intake.gone(node_id, "left", t + 0.05)
        world.update(t + 0.05)
    assert [d.actor_id for d in world.despawns] == [f"n{k}" for k in range(30, 80)]


def test_poses_stamped_on_a_local_clock_are_judged_in_session_time() -> None:
    # A live session stamps a pose's arrival on its host's monotonic clock and gives the view
    # the conversion (session = local + 1000 s here). A pose sent at session time 1000.50 and
    # stamped at local 0.52 arrived 20 ms after it was sent: that is its latency, and it is
    # plausible; unconverted, the stamp would be 1000 s before the send and refused.
    world = WorldView("me", S)
    world.intake.pose_stamp_to_session = lambda local_t: local_t + 1000.0
    world.intake.present("a")
    world.intake.pose("a", encode_pose(Pose(1, 1000.50, 0, 0)), 0.52)
    world.update(1000.53)
    assert "a" in world.egos and not world.rejected
    assert world.stats["a"].summary(1000.53).latency_p50_ms == pytest.approx(20.0, abs=1e-6)
