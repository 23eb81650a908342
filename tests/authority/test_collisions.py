"""The collision matrix on hand-built actors: geometry, contact tracking, analytic impulses."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse.authority.collisions import Actors, CollisionMatrix, impulse_magnitude
from carlaverse.authority.obb import Overlaps, aabb_half_extents, box_overlaps, sweep_and_prune
from carlaverse.messages import ACTOR_KINDS, ContactEnded, ContactStarted

CAR = ACTOR_KINDS.index("car")


def actors(*boxes: dict) -> Actors:
    """Actors from dicts: id, x, y, yaw, vx, vy, ego, mass, e, length, width, z, h."""

    def col(key: str, default: float) -> np.ndarray:
        return np.array([b.get(key, default) for b in boxes], dtype=np.float64)

    return Actors(
        ids=[b["id"] for b in boxes],
        kind=np.array([b.get("kind", CAR) for b in boxes], dtype=np.intp),
        is_ego=np.array([b.get("ego", False) for b in boxes]),
        x=col("x", 0), y=col("y", 0), z=col("z", 0), yaw=col("yaw", 0),
        hl=col("length", 4.5) / 2, hw=col("width", 1.8) / 2, h=col("h", 1.5),
        vx=col("vx", 0), vy=col("vy", 0), mass=col("mass", 1500), restitution=col("e", 0.2),
    )  # fmt: skip


class Seq:
    def __init__(self) -> None:
        self.n = 0

    def __call__(self) -> int:
        self.n += 1
        return self.n


# ---------------------------------------------------------------- geometry


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(2, 60))
def test_sweep_and_prune_finds_exactly_the_overlapping_bounds(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0, 40, n), rng.uniform(0, 40, n)
    ex, ey = rng.uniform(0.2, 5, n), rng.uniform(0.2, 5, n)
    i, j = sweep_and_prune(x - ex, x + ex, y - ey, y + ey)
    found = {tuple(sorted(p)) for p in zip(i.tolist(), j.tolist(), strict=True)}
    brute = {
        (a, b)
        for a, b in itertools.combinations(range(n), 2)
        if abs(x[a] - x[b]) <= ex[a] + ex[b] and abs(y[a] - y[b]) <= ey[a] + ey[b]
    }
    assert found == brute
    assert len(found) == len(i)  # no pair twice


def overlaps_of(a: Actors) -> Overlaps:
    return box_overlaps(np.array([0]), np.array([1]), a.x, a.y, a.yaw, a.hl, a.hw, a.z, a.h)


def test_boxes_five_centimetres_apart_do_not_touch_and_five_into_each_other_do() -> None:
    apart = actors({"id": "a", "x": 0.0}, {"id": "b", "x": 4.5 + 0.05})
    assert not overlaps_of(apart).hit[0]
    into = actors({"id": "a", "x": 0.0}, {"id": "b", "x": 4.5 - 0.05})
    o = overlaps_of(into)
    assert o.hit[0] and o.depth[0] == pytest.approx(0.05)
    assert o.normal[0] == pytest.approx([-1.0, 0.0])  # from b (ahead) into a


def test_rotated_box_corner_inside_and_just_outside() -> None:
    # b turned 45°: its corner (-hl, +hw) points at a's front face, at a's centre line.
    c = math.cos(math.pi / 4)
    reach, lift = (2.25 + 0.9) * c, (2.25 - 0.9) * c  # [m] corner offset from b's centre
    at = {"id": "b", "y": lift, "yaw": math.pi / 4}
    far = actors({"id": "a"}, {**at, "x": 2.25 + reach + 0.05})
    near = actors({"id": "a"}, {**at, "x": 2.25 + reach - 0.05})
    assert not overlaps_of(far).hit[0]
    o = overlaps_of(near)
    assert o.hit[0] and o.depth[0] == pytest.approx(0.05)
    assert o.normal[0] == pytest.approx([-1.0, 0.0])  # a's face is the separating axis


def test_boxes_at_different_heights_do_not_touch() -> None:
    bridge = actors({"id": "a", "z": 0.0}, {"id": "b", "x": 1.0, "z": 6.0})
    assert not overlaps_of(bridge).hit[0]


def test_aabb_of_a_turned_box_contains_its_corners() -> None:
    ex, ey = aabb_half_extents(np.array([2.0]), np.array([1.0]), np.array([math.pi / 2]))
    assert ex[0] == pytest.approx(1.0) and ey[0] == pytest.approx(2.0)


# ---------------------------------------------------------------- contacts and impulses


def drive_into(matrix: CollisionMatrix, seq: Seq, ego_x: list[float], **npc: float) -> list:
    ticks = []
    for k, x in enumerate(ego_x):
        scene = actors({"id": "ego", "ego": True, "x": x, "vx": 5.0, "mass": 1200, "e": 0.2},
                       {"id": "npc", "x": 10.0, "mass": 1500, "e": 0.4, **npc})  # fmt: skip
        ticks.append(matrix.step(100.0 + k * 0.02, scene, seq))
    return ticks


def test_ego_into_stopped_npc_one_analytic_impulse_then_contact_end() -> None:
    matrix, seq = CollisionMatrix(), Seq()
    approach = [10.0 - 4.5 - 0.3 + 0.1 * k for k in range(8)]  # 5 m/s at 50 Hz
    ticks = drive_into(matrix, seq, approach + [approach[-1]] * 5 + [0.0])
    impulses = [imp for tick in ticks for imp in tick.impulses]
    assert len(impulses) == 1, "one impulse per contact, at its start"
    node_id, imp = impulses[0]
    e, m1, m2, v = (0.2 + 0.4) / 2, 1200.0, 1500.0, 5.0
    expected = (1 + e) * v / (1 / m1 + 1 / m2)  # [N·s]
    assert node_id == "ego" and imp.other_id == "npc" and imp.other_kind == "car"
    assert imp.impulse[0] == pytest.approx(-expected, rel=1e-9)
    assert imp.impulse[1] == pytest.approx(0.0, abs=1e-9)
    assert imp.normal == pytest.approx((-1.0, 0.0, 0.0))
    assert imp.relative_speed_mps == pytest.approx(v)
    assert 7.75 <= imp.point[0] <= 7.75 + 0.1  # [m] in the overlap: npc rear .. ego front
    assert imp.point[2] == pytest.approx(0.75)  # [m] half the common height
    started = [e for t in ticks for e in t.events if isinstance(e, ContactStarted)]
    ended = [e for t in ticks for e in t.events if isinstance(e, ContactEnded)]
    assert len(started) == len(ended) == 1 and started[0].contact_id == ended[0].contact_id
    assert [t.hit_npcs for t in ticks if t.hit_npcs] == [["npc"]]


def test_two_egos_get_equal_and_opposite_impulses() -> None:
    matrix = CollisionMatrix()
    scene = actors(
        {"id": "a", "ego": True, "x": 0.0, "vx": 8.0, "mass": 1500},
        {"id": "b", "ego": True, "x": 2.5, "y": 0.0, "yaw": 2.0, "vx": -3.0, "vy": 4.0,
         "mass": 90, "length": 1.8, "width": 0.7, "kind": ACTOR_KINDS.index("bicycle")},
    )  # fmt: skip
    tick = matrix.step(5.0, scene, Seq())
    by_node = dict(tick.impulses)
    assert set(by_node) == {"a", "b"}
    ia, ib = np.array(by_node["a"].impulse), np.array(by_node["b"].impulse)
    assert np.linalg.norm(ia) > 0
    assert ia == pytest.approx(-ib)
    assert by_node["a"].normal == pytest.approx(tuple(-np.array(by_node["b"].normal)))
    assert by_node["a"].other_kind == "bicycle" and by_node["b"].other_kind == "car"
    assert by_node["a"].contact_id == by_node["b"].contact_id
    assert tick.hit_npcs == []


def test_separating_contact_gives_no_push() -> None:
    assert impulse_magnitude(np.array([-1.0, 0.0]), np.array([-1.0, 0.0]), 1000, 1000, 0.5) == 0.0


def test_npc_npc_contacts_are_ignored_unless_asked_for() -> None:
    scene = actors({"id": "p1", "x": 0.0}, {"id": "p2", "x": 1.0})
    assert CollisionMatrix().step(0.0, scene, Seq()).events == []
    both = CollisionMatrix(npc_npc=True).step(0.0, scene, Seq())
    assert len(both.events) == 1 and both.impulses == [] and both.hit_npcs == []


def test_actor_that_vanishes_ends_its_contact() -> None:
    matrix, seq = CollisionMatrix(), Seq()
    matrix.step(0.0, actors({"id": "ego", "ego": True}, {"id": "npc", "x": 2.0}), seq)
    tick = matrix.step(0.02, actors({"id": "ego", "ego": True}), seq)
    assert [type(e) for e in tick.events] == [ContactEnded]
    assert matrix.active == []
