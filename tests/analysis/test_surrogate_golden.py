"""Surrogate safety measures on constructed encounters whose answers are worked out by hand."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from carlaverse.analysis import footprints
from carlaverse.analysis.lanes import LaneIndex
from carlaverse.analysis.surrogate import (
    Thresholds,
    by_concern,
    conflicts_by_concern,
    crossing_conflicts,
    measure,
    pair_measures,
)
from carlaverse.analysis.tracks import Actor, Tracks
from carlaverse.messages import MapLane, MapReply

RATE_HZ = 10.0
CAR = (4.5, 1.8)  # [m] length, width
BIKE = (1.8, 0.6)


def straight(t: np.ndarray, x0: float, y0: float, heading: float, speed: float) -> np.ndarray:
    """(5, T): x, y, yaw, vx, vy of a constant-velocity road user."""
    vx, vy = speed * math.cos(heading), speed * math.sin(heading)
    return np.stack([x0 + vx * t, y0 + vy * t, np.full_like(t, heading),
                     np.full_like(t, vx), np.full_like(t, vy)])  # fmt: skip


def tracks(duration_s: float, *users: tuple[str, tuple, np.ndarray]) -> Tracks:
    t = np.arange(round(duration_s * RATE_HZ) + 1) / RATE_HZ
    actors = [
        Actor(name, "car" if size == CAR else "bicycle", True, *size) for name, size, _ in users
    ]
    motion = np.stack([path(t) for _, _, path in users])
    return Tracks(t, actors, *(motion[:, c] for c in range(5)))


def test_head_on_ttc_is_the_bumper_gap_over_the_closing_speed() -> None:
    # 50 m apart, 10 m/s each towards the other: contact when the gap of 50 - 4.5 m closes at
    # 20 m/s, TTC(t) = 2.275 - t. Over 2 s the minimum is 0.275 s at t = 2; TTC < 1.5 s from
    # t > 0.775 s: the 13 samples 0.8 ... 2.0 at 10 Hz, 1.3 s.
    tr = tracks(2.0, ("a", CAR, lambda t: straight(t, 0, 0, 0.0, 10)),
                ("b", CAR, lambda t: straight(t, 50, 0, math.pi, 10)))  # fmt: skip
    p = pair_measures(tr, 0, 1, Thresholds())
    assert p.min_ttc_s == pytest.approx(0.275, abs=1e-9)
    assert p.t_min_ttc == pytest.approx(2.0)
    assert p.ttc_below_s == pytest.approx(1.3, abs=1e-9)
    assert p.min_gap_m == pytest.approx(50 - 4.5 - 40, abs=1e-9)
    # DRAC = 20^2 / (2 gap) = 200 / gap with gap(t) = 45.5 - 20 t. Its peak, at t = 2 s over
    # a 5.5 m gap, is 400 / 11 = 36.4 m/s^2, beyond any tyre (mu g = 9.8 m/s^2 for mu = 1):
    # not the headline. Within the 10 m/s^2 limit while gap >= 20 m, t <= 1.275 s: the last
    # such sample is t = 1.2 s, gap 21.5 m, DRAC 200 / 21.5. Above it: the 8 samples 1.3 ... 2.0.
    assert p.peak_drac_mps2 == pytest.approx(400 / 11, rel=1e-9)
    assert p.max_drac_mps2 == pytest.approx(200 / 21.5, rel=1e-9)
    assert p.t_max_drac == pytest.approx(1.2)
    assert p.drac_implausible_s == pytest.approx(0.8, abs=1e-9)


def test_car_following_ttc_and_drac() -> None:
    # Leader's rear 20 - 2.25 m, follower's front 2.25 m: gap 15.5 m at t = 0, closing 5 m/s.
    # At t = 1 s the gap is 10.5 m: TTC 2.1 s, DRAC = 5^2 / (2 * 10.5).
    tr = tracks(1.0, ("follower", CAR, lambda t: straight(t, 0, 0, 0.0, 15)),
                ("leader", CAR, lambda t: straight(t, 20, 0, 0.0, 10)))  # fmt: skip
    p = pair_measures(tr, 0, 1, Thresholds())
    assert p.min_ttc_s == pytest.approx(2.1, abs=1e-9)
    assert p.min_gap_m == pytest.approx(10.5, abs=1e-9)
    assert p.max_drac_mps2 == pytest.approx(25 / 21, rel=1e-9)
    assert p.peak_drac_mps2 == p.max_drac_mps2 and p.drac_implausible_s == 0.0
    assert p.ttc_below_s == 0.0


def test_perpendicular_approach_ttc_uses_the_rotated_footprint() -> None:
    # a from (-20, 0) east, b from (0, -20) north, both 10 m/s: b's long side faces a's nose.
    # On x the reach is a's half length + b's half width, 2.25 + 0.9 = 3.15 m, likewise on y:
    # TTC(0) = (20 - 3.15) / 10 = 1.685 s.
    tr = tracks(0.0, ("a", CAR, lambda t: straight(t, -20, 0, 0.0, 10)),
                ("b", CAR, lambda t: straight(t, 0, -20, math.pi / 2, 10)))  # fmt: skip
    assert pair_measures(tr, 0, 1, Thresholds()).min_ttc_s == pytest.approx(1.685, abs=1e-9)


def test_side_by_side_at_the_same_speed_never_collides() -> None:
    tr = tracks(3.0, ("a", CAR, lambda t: straight(t, 0, 0, 0.0, 12)),
                ("b", CAR, lambda t: straight(t, 0, 3.5, 0.0, 12)))  # fmt: skip
    p = pair_measures(tr, 0, 1, Thresholds())
    assert math.isinf(p.min_ttc_s) and math.isnan(p.t_min_ttc)
    assert p.max_drac_mps2 == 0.0
    assert p.min_gap_m == pytest.approx(3.5 - 1.8, abs=1e-9)


def test_gap_between_a_box_and_a_turned_square() -> None:
    # 4 x 2 box at the origin; a 2 x 2 square turned 45 degrees at (5, 0): its near corner is
    # at x = 5 - sqrt(2), the box's front at x = 2.
    a = footprints.corners(np.array([0.0, 0.0]), np.array(0.0), 4.0, 2.0)
    b = footprints.corners(np.array([5.0, 0.0]), np.array(math.pi / 4), 2.0, 2.0)
    assert footprints.gap(a, b) == pytest.approx(3 - math.sqrt(2), abs=1e-12)
    inside = footprints.corners(np.array([2.5, 0.5]), np.array(0.3), 2.0, 2.0)
    assert footprints.gap(a, inside) == 0.0


def test_pet_at_a_perpendicular_crossing() -> None:
    # The car passes the origin at t = 2 s (10 m/s east), the bike at t = 3 s (5 m/s north).
    # The car's footprint clears the point 2.25 m / 10 m/s after, the bike's reaches it
    # 0.9 m / 5 m/s before: PET = (3 - 0.18) - (2 + 0.225) = 0.595 s.
    tr = tracks(6.0, ("car", CAR, lambda t: straight(t, -20, 0, 0.0, 10)),
                ("bike", BIKE, lambda t: straight(t, 0, -15, math.pi / 2, 5)))  # fmt: skip
    (c,) = crossing_conflicts(tr, 0, 1, Thresholds())
    assert (c.first, c.second) == ("car", "bike")
    assert (c.x, c.y) == (pytest.approx(0.0, abs=1e-9), pytest.approx(0.0, abs=1e-9))
    assert c.t_first_leaves == pytest.approx(2.225, abs=1e-9)
    assert c.t_second_arrives == pytest.approx(2.82, abs=1e-9)
    assert c.pet_s == pytest.approx(0.595, abs=1e-9)
    assert c.angle_deg == pytest.approx(90.0)


def test_pet_at_an_oblique_crossing_and_the_order_of_arrival() -> None:
    # Paths crossing at 60 degrees at (10, 0): the bike (first, 4 m/s) passes at t = 2.5 s,
    # the car (8 m/s) at t = 4 s. PET = (4 - 2.25/8) - (2.5 + 0.9/4) = 0.99375 s.
    heading = math.radians(60)
    x0, y0 = 10 - 10 * math.cos(heading), -10 * math.sin(heading)  # 10 m before the point
    tr = tracks(8.0, ("car", CAR, lambda t: straight(t, -22, 0, 0.0, 8)),
                ("bike", BIKE, lambda t: straight(t, x0, y0, heading, 4)))  # fmt: skip
    (c,) = crossing_conflicts(tr, 0, 1, Thresholds())
    assert (c.first, c.second) == ("bike", "car")
    assert (c.x, c.y) == (pytest.approx(10.0, abs=1e-9), pytest.approx(0.0, abs=1e-9))
    assert c.pet_s == pytest.approx(4 - 2.25 / 8 - 2.5 - 0.9 / 4, abs=1e-9)
    assert c.angle_deg == pytest.approx(60.0)


def test_following_on_one_lane_is_no_crossing_and_far_pairs_are_not_measured() -> None:
    tr = tracks(4.0, ("a", CAR, lambda t: straight(t, 0, 0, 0.0, 10)),
                ("b", CAR, lambda t: straight(t, 15, 0, 0.0, 10)),
                ("far", CAR, lambda t: straight(t, 0, 500, 0.0, 10)))  # fmt: skip
    pairs, conflicts = measure(tr, Thresholds(near_m=30))
    assert [(p.a, p.b) for p in pairs] == [("a", "b")]
    assert conflicts == []


def test_absent_samples_are_left_out_of_the_pair() -> None:
    # b exists only for the first second; the pair is measured over that second alone.
    tr = tracks(3.0, ("a", CAR, lambda t: straight(t, 0, 0, 0.0, 10)),
                ("b", CAR, lambda t: straight(t, 40, 0, math.pi, 10)))  # fmt: skip
    for c in (tr.x, tr.y, tr.yaw, tr.vx, tr.vy):
        c[1, tr.t > 1.0] = np.nan
    p = pair_measures(tr, 0, 1, Thresholds())
    assert p.min_ttc_s == pytest.approx((40 - 4.5) / 20 - 1.0, abs=1e-9)


def test_cars_queued_at_standstill_are_no_encounter() -> None:
    # At a stop line the follower creeps at 0.4 m/s towards a stopped leader, 1 m behind its
    # rear at t = 0: TTC(t) = (1 - 0.4 t) / 0.4, 0.5 s at t = 2 s, and DRAC 0.4^2 / (2 gap).
    # Both are below the 0.5 m/s standstill speed throughout: queued, not an encounter.
    follower_x0 = -(1.0 + CAR[0])  # centres a car length plus the 1 m gap apart
    tr = tracks(2.0, ("follower", CAR, lambda t: straight(t, follower_x0, 0, 0.0, 0.4)),
                ("leader", CAR, lambda t: straight(t, 0, 0, 0.0, 0.0)))  # fmt: skip
    p = pair_measures(tr, 0, 1, Thresholds())
    assert math.isinf(p.min_ttc_s) and p.ttc_below_s == 0.0 and p.max_drac_mps2 == 0.0
    assert p.queued_s == pytest.approx(2.1, abs=1e-9)  # all 21 samples, 0.1 s each
    assert p.min_gap_m == pytest.approx(0.2, abs=1e-9)  # the gap is still measured
    # the same creep with the standstill speed set below it is an encounter again, by hand
    p = pair_measures(tr, 0, 1, Thresholds(standstill_mps=0.3))
    assert p.min_ttc_s == pytest.approx(0.2 / 0.4, abs=1e-9)
    assert p.max_drac_mps2 == pytest.approx(0.4**2 / (2 * 0.2), rel=1e-9)
    assert p.queued_s == 0.0


def test_pairs_with_a_human_come_first() -> None:
    # Two NPCs on a head-on course (TTC far below the human's) still come after the human's
    # pair: a researcher reads the participants' encounters first.
    users = [("npc-a", CAR, lambda t: straight(t, 0, 100, 0.0, 10)),
             ("npc-b", CAR, lambda t: straight(t, 40, 100, math.pi, 10)),
             ("human", CAR, lambda t: straight(t, 0, 0, 0.0, 10)),
             ("npc-c", CAR, lambda t: straight(t, 25, 0, 0.0, 5))]  # fmt: skip
    tr = tracks(1.0, *users)
    tr.actors[:] = [dataclasses.replace(a, human=a.id == "human") for a in tr.actors]
    pairs = by_concern(measure(tr, Thresholds())[0])
    assert [(p.a, p.b, p.human) for p in pairs] == [
        ("human", "npc-c", True), ("npc-a", "npc-b", False)
    ]  # fmt: skip
    # human: gap 25 - 4.5 = 20.5 m closing 5 m/s, 15.5 m at t = 1: TTC 3.1 s; npc-a/b: 40 -
    # 4.5 = 35.5 m closing 20 m/s, 15.5 m at t = 1: 0.775 s, less, yet second
    assert pairs[0].min_ttc_s == pytest.approx(3.1, abs=1e-9)
    assert pairs[1].min_ttc_s == pytest.approx(0.775, abs=1e-9)


def test_a_point_is_on_the_nearest_lane_within_its_half_width() -> None:
    # A 3.5 m lane along y = 0 and a 2 m sidewalk along y = 3: a point 1.9 m north of the lane's
    # centreline is 1.1 m from the sidewalk's (nearer); 4 m north of the sidewalk is beyond its
    # 1 m half width plus the 1 m margin (half a car's width beyond its edge, half a sample step).
    road_map = MapReply(1, "t", (0, -5, 50, 10), [
        MapLane("road_0", "road", 3.5, [(0.0, 0.0), (50.0, 0.0)]),
        MapLane("walk_0", "sidewalk", 2.0, [(0.0, 3.0), (50.0, 3.0)]),
    ])  # fmt: skip
    index = LaneIndex(road_map)
    assert index.lane_at(10.3, 0.4) == "road_0"
    assert index.lane_at(10.3, 1.9) == "walk_0"
    assert index.lane_at(10.3, 7.0) == ""
    assert index.lane_at(math.nan, 0.0) == ""
    xs = np.array([5.0, 6.0, 7.0, 8.0, 9.0])
    assert index.route(xs, np.array([0.0, 0.2, 3.1, 2.9, 0.0])) == ["road_0", "walk_0", "road_0"]
    assert LaneIndex(None).lane_at(0.0, 0.0) == ""


def braking_to_rest(t: np.ndarray) -> np.ndarray:
    """(5, T): a car at 5 m/s braking at 2.5 m/s^2 from t = 0 to rest at t = 2 s, 5 m on, its
    front then 2.5 m (the traffic model's minimum gap) behind a rear at x = 0."""
    v0, decel = 5.0, 2.5
    moving = np.minimum(t, v0 / decel)
    x = -2.5 - 5.0 - CAR[0] / 2 + v0 * moving - decel * moving**2 / 2
    zeros = np.zeros_like(t)
    return np.stack([x, zeros, zeros, v0 - decel * moving, zeros])


@pytest.mark.parametrize("human", [False, True])
def test_npcs_pulling_up_into_a_queue_are_no_encounter(human: bool) -> None:
    # Constant-velocity TTC while braking: gap(t) = 7.5 - 5 t + 1.25 t^2, speed 5 - 2.5 t, so
    # TTC = gap / speed = 0.5 (u + 2 / u) with u = 2 - t: below 1.5 s for 1 < u < 2 (t in
    # 0 ... 1 s: the 9 samples 0.1 ... 0.9), least at u = sqrt 2; on the 10 Hz grid at t = 0.6,
    # 0.5 (1.4 + 2 / 1.4). From t = 1.9 s the follower is below 0.5 m/s: both at rest.
    users = [("follower", CAR, braking_to_rest),
             ("stopped", CAR, lambda t: straight(t, CAR[0] / 2, 0, 0.0, 0.0))]  # fmt: skip
    tr = tracks(4.0, *users)
    tr.actors[:] = [dataclasses.replace(a, human=human and a.id == "follower") for a in tr.actors]
    p = pair_measures(tr, 0, 1, Thresholds())
    assert p.min_gap_m == pytest.approx(2.5, abs=1e-9)
    if human:  # a participant braking late is what a study measures: its TTC stays
        assert p.min_ttc_s == pytest.approx(0.5 * (1.4 + 2 / 1.4), abs=1e-9)
        assert p.t_min_ttc == pytest.approx(0.6)
        assert p.ttc_below_s == pytest.approx(0.9, abs=1e-9)
        assert p.queued_s == pytest.approx(2.2, abs=1e-9)  # at rest: t = 1.9 ... 4.0
    else:  # the NPCs come to rest 2.5 m apart, untouched, within the 10 s horizon: queued
        assert math.isinf(p.min_ttc_s) and p.ttc_below_s == 0.0
        assert p.queued_s == pytest.approx(4.1, abs=1e-9)  # every one of the 41 samples
        # DRAC of the approach stays: at t = 0, 5^2 / (2 * 7.5)
        assert p.max_drac_mps2 == pytest.approx(25 / 15, rel=1e-9)


def test_crossing_conflicts_with_a_human_come_first() -> None:
    # Two copies of the perpendicular crossing above (PET 0.595 s), one 100 m north with
    # slower crossers (the bike at 2.5 m/s: it reaches the point 6 s after 0, the car's
    # footprint cleared it at 2.225 s, PET (6 - 0.36) - 2.225 = 3.415 s). Only the slow copy
    # has a participant: it comes first though its PET is larger.
    tr = tracks(8.0, ("car", CAR, lambda t: straight(t, -20, 0, 0.0, 10)),
                ("bike", BIKE, lambda t: straight(t, 0, -15, math.pi / 2, 5)),
                ("human-car", CAR, lambda t: straight(t, -20, 100, 0.0, 10)),
                ("slow-bike", BIKE, lambda t: straight(t, 0, 85, math.pi / 2, 2.5)))  # fmt: skip
    tr.actors[:] = [dataclasses.replace(a, human=a.id == "human-car") for a in tr.actors]
    found = conflicts_by_concern(measure(tr, Thresholds())[1])
    assert [(c.first, c.second, c.human) for c in found] == [
        ("human-car", "slow-bike", True), ("car", "bike", False)]  # fmt: skip
    assert found[0].pet_s == pytest.approx(6 - 0.9 / 2.5 - 2.225, abs=1e-9)
    assert found[1].pet_s == pytest.approx(0.595, abs=1e-9)


def test_coming_to_rest_beside_a_crossing_car_is_no_queue() -> None:
    # The same braking NPC, but the car it stops 2.5 m short of faces north (waiting on the
    # cross street): its west side at x = 0, where the other's rear was. At rest they are not
    # one queue (headings 90 degrees apart), so the approach keeps its TTC, as worked out in
    # the test above, and only the standing instants (t >= 1.9 s) are queued.
    users = [("follower", CAR, braking_to_rest),
             ("crossing", CAR, lambda t: straight(t, CAR[1] / 2, 0, math.pi / 2, 0.0))]  # fmt: skip
    tr = tracks(4.0, *users)
    tr.actors[:] = [dataclasses.replace(a, human=False) for a in tr.actors]
    p = pair_measures(tr, 0, 1, Thresholds())
    assert p.min_gap_m == pytest.approx(2.5, abs=1e-9)
    assert p.min_ttc_s == pytest.approx(0.5 * (1.4 + 2 / 1.4), abs=1e-9)
    assert p.queued_s == pytest.approx(2.2, abs=1e-9)
