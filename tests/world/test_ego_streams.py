"""The world view's egos (`world/ego_streams.py`): poses decoded once and applied a batch at a
time, actors fed only when read, statistics per sender."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.scripted.trajectories import CirclePath

from carlaverse import messages as m
from carlaverse.support.stats import percentile
from carlaverse.world import ego_streams, world_view
from carlaverse.world.remote_actor import InterpolationSettings, RemoteActor
from carlaverse.world.world_view import WorldView

CIRCLE = CirclePath(radius=30.0, speed_mps=14.0)


def rows(ids_poses: list[tuple[str, m.Pose]]) -> tuple[list[str], bytes]:
    """A digest's ids and rows, as the inbound handler hands them over."""
    return [i for i, _ in ids_poses], b"".join(m.encode_pose(p) for _, p in ids_poses)


def joined(*node_ids: str, mode: str = "present") -> WorldView:
    world = WorldView("me", InterpolationSettings(render_mode=mode))  # type: ignore[arg-type]
    for node_id in node_ids:
        world.intake.present(node_id)
    world.update(0.0)
    return world


def test_two_samples_of_one_sender_in_one_update_are_both_applied_in_order() -> None:
    world = joined("a", "b")
    world.intake.pose_rows(*rows([("a", CIRCLE.pose_at(1.00)), ("b", CIRCLE.pose_at(1.00))]), 1.01)
    world.intake.pose_rows(*rows([("a", CIRCLE.pose_at(1.02)), ("a", CIRCLE.pose_at(1.04))]), 1.05)
    world.update(1.05)
    assert world.stats["a"].count == 3 and world.stats["b"].count == 1
    actor = world.egos["a"]
    assert actor.samples_received == 3
    assert actor.newest is not None and actor.newest.t == pytest.approx(1.04)
    assert actor.timing.interval_s == pytest.approx(0.02, abs=1e-6)


def test_single_poses_and_relayed_rows_of_one_sender_apply_in_arrival_order() -> None:
    """A pose on its own key (`intake.pose`) and rows relayed together (`intake.pose_rows`,
    the authority's digest): interleaved in one update, they are applied in the order they
    came, and this node's own row among the relayed ones is skipped, not counted."""
    world = joined("a")
    ts = [1.00, 1.02, 1.04, 1.06, 1.08, 1.10]
    for k, t in enumerate(ts):
        wire = m.encode_pose(m.Pose(k + 1, t, float(k), 0.0))
        if k in (1, 2, 4):
            world.intake.pose_rows(["me", "a"], wire + wire, t)
        else:
            world.intake.pose("a", wire, t)
    world.update(1.10)
    actor = world.egos["a"]
    assert world.stats["a"].count == 6 and actor.samples_received == 6  # none taken as late
    assert actor.newest is not None and (actor.newest.seq, actor.newest.x) == (6, 5.0)
    assert world.rejected == {}
    # a wire pose is what `decode_pose` makes of the bytes, field for field
    wired = m.Pose(7, 1.12, 1.5, -2.25, 0.5, 0.1, 0.2, 0.3, 14.0, 0.5, 0.0, 0.0, 0.0, 0.25, 1.0)
    world.intake.pose("a", m.encode_pose(wired), 1.12)
    world.update(1.12)
    assert world.egos["a"].newest == m.decode_pose(m.encode_pose(wired))


def test_digests_drained_together_drop_only_their_bad_rows_and_count_them() -> None:
    world = joined("a", "b")
    nan = bytearray(m.encode_pose(m.Pose(2, 1.02, 0.0, 0.0)))
    nan[16:20] = b"\x00\x00\xc0\x7f"  # x = NaN
    first = rows([("a", m.Pose(1, 1.00, 1.0, 0.0)), ("b", m.Pose(1, 1.00, 2.0, 0.0))])
    world.intake.pose_rows(*first, 1.01)
    world.intake.pose_rows(["a", "b"], bytes(nan) + m.encode_pose(m.Pose(2, 1.02, 3.0, 0.0)), 1.03)
    world.intake.pose("a", m.encode_pose(m.Pose(3, 1.04, 4.0, 0.0)), 1.05)
    world.update(1.05)
    assert world.dropped["pose"] == 1 and world.rejected == {}
    assert world.stats["a"].count == 2 and world.stats["b"].count == 2
    a, b = world.egos["a"].newest, world.egos["b"].newest
    assert a is not None and (a.seq, a.x) == (3, 4.0)  # the wire pose after the digests
    assert b is not None and (b.seq, b.x) == (2, 3.0)
    # each row keeps its own digest's arrival time
    summary = world.stats["b"].summary(1.05)
    assert (summary.latency_p50_ms, summary.latency_p99_ms) == pytest.approx((10.0, 10.0))


def test_poses_the_decoder_refuses_are_counted_and_dropped_and_the_rest_kept_in_order() -> None:
    """A pose comes in as its bytes (the callback does not look inside): whatever
    `decode_pose` refuses — empty, a byte short, an unknown layout, a NaN, a time out of
    range — is counted under `pose` by the update that drains it; the poses around it apply."""
    world = joined("a")
    good = m.encode_pose(m.Pose(1, 1.0, 0.0, 0.0))
    nan = bytearray(good)
    nan[16:20] = b"\x00\x00\xc0\x7f"  # x = NaN
    bad = [b"", good[:-1], b"\x09" + good[1:], bytes(nan), m.encode_pose(m.Pose(1, 2e12, 0, 0))]
    for k, payload in enumerate(bad):
        with pytest.raises(m.MessageError):
            m.decode_pose(payload)
        world.intake.pose("a", payload, 1.0)
        world.intake.pose("a", m.encode_pose(m.Pose(k + 1, 1.0 + k / 50, float(k), 0.0)), 1.0)
    world.update(1.1)
    assert world.dropped["pose"] == len(bad) and world.rejected == {}
    assert world.stats["a"].count == len(bad)
    newest = world.egos["a"].newest
    assert newest is not None and (newest.seq, newest.x) == (5, 4.0)


def test_lazy_actors_draw_exactly_what_eagerly_fed_actors_draw() -> None:
    """The same samples, given to a world view a batch per update and to a `RemoteActor` one by
    one: every frame drawn is the same, in both render modes."""
    for mode in ("present", "past"):
        settings = InterpolationSettings(render_mode=mode)  # type: ignore[arg-type]
        world = joined("a", mode=mode)
        eager = RemoteActor("a", settings)
        for k in range(1, 120):
            t = 10.0 + 0.02 * k
            pose = m.decode_pose(m.encode_pose(CIRCLE.pose_at(t)))  # as it travels
            rx = t + 0.004 + 0.003 * math.sin(k)  # jittered latency
            world.intake.pose("a", m.encode_pose(pose), rx)
            eager.add(pose, rx)
            if k % 3 == 0:  # a frame every 60 ms, after the samples that arrived by then
                now = rx + 0.001
                world.update(now)
                (lazy,) = world.ego_views(now)
                mine = eager.present(now) if mode == "present" else eager.past(lazy.render_t, now)
                assert mine is not None
                assert (lazy.x, lazy.y, lazy.yaw, lazy.phase) == pytest.approx(
                    (mine.x, mine.y, mine.yaw, mine.phase)
                ), (mode, k)


def test_a_view_that_is_not_read_keeps_a_bounded_ring_per_sender() -> None:
    world = joined("a")
    for k in range(1, 500):
        t = 0.02 * k
        world.intake.pose("a", m.encode_pose(m.Pose(k, t, float(k), 0.0)), t)
    world.update(10.0)
    assert world.stats["a"].count == 499  # every sample counted ...
    actor = world.egos["a"]  # ... but the actor, read now, takes only the ring's newest
    assert actor.samples_received == ego_streams.RING
    assert actor.newest is not None and actor.newest.seq == 499


def test_our_own_row_in_a_digest_is_skipped_and_an_intruder_grows_nothing() -> None:
    world = joined("a")
    slots = len(world.streams)
    pose = m.Pose(1, 1.0, 0.0, 0.0)
    senders = ["me", "a", "mallory", "authority"]
    world.intake.pose_rows(*rows([(sender, pose) for sender in senders]), 1.0)
    world.update(1.0)
    assert set(world.egos) == {"a"} and set(world.stats) == {"a"}
    assert world.rejected == {"pose_from_absent_node": 2}  # not our own row
    assert len(world.streams) == slots  # no place kept for who never joined


def test_statistics_match_their_definitions() -> None:
    """Loss from the sequence gaps, RFC 3550 jitter, latency percentiles and rate, against a
    plain computation over the same samples."""
    world = joined("a")
    latencies, transit_prev, jitter = [], None, 0.0
    sent = [k for k in range(1, 301) if k % 10 != 0]  # every tenth sample lost
    for k in sent:
        t = 0.02 * k
        latency = 0.005 + 0.002 * ((k * 7) % 5)
        world.intake.pose("a", m.encode_pose(m.Pose(k, t, 0.0, 0.0)), t + latency)
        latencies.append(latency)
        if transit_prev is not None:
            jitter += (abs(latency - transit_prev) - jitter) / 16
        transit_prev = latency
    world.update(6.1)
    summary = world.stats["a"].summary(6.1)
    span = (0.02 * sent[-1] + latencies[-1]) - (0.02 * sent[0] + latencies[0])
    assert summary.samples == len(sent)
    assert summary.loss == pytest.approx(1 - len(sent) / (sent[-1] - sent[0] + 1), abs=1e-4)
    assert summary.jitter_ms == pytest.approx(jitter * 1e3, abs=1e-3)
    assert summary.latency_p50_ms == pytest.approx(percentile(latencies, 0.5) * 1e3, abs=1e-3)
    assert summary.latency_p99_ms == pytest.approx(percentile(latencies, 0.99) * 1e3, abs=1e-3)
    assert summary.rate_hz == pytest.approx((len(sent) - 1) / span, abs=0.01)


def test_a_departed_senders_place_is_reused_beyond_the_limit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(world_view, "STATS_LIMIT", 8)
    world = joined()
    for k in range(20):
        node = f"n{k}"
        world.intake.present(node)
        world.intake.pose(node, m.encode_pose(m.Pose(1, 0.0, 0.0, 0.0)), 0.0)
        world.intake.gone(node, "left", 0.0)
    world.intake.present("last")
    world.intake.pose("last", m.encode_pose(m.Pose(7, 0.0, 0.0, 0.0)), 0.0)
    world.update(0.0)
    assert len(world.streams) <= 8 and "last" in world.egos
    assert world.stats["last"].summary(0.0).samples == 1  # nothing of the slot's former owner
    assert world.egos["last"].newest == m.Pose(7, 0.0, 0.0, 0.0)
