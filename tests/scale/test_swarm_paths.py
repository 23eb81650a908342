"""Block loops as arrays agree with a scripted node's polyline over the same block."""

from __future__ import annotations

import math

import numpy as np
from carlaverse_nodes.scripted.trajectories import PolylinePath

from carlaverse.swarm.paths import MAX_SPEED_MPS, MIN_SPEED_MPS, BlockLoops


def test_a_block_loop_is_the_polyline_around_its_corners() -> None:
    loops = BlockLoops(np.array([(300.0, 150.0)]), np.array([(150.0, 100.0)]), np.array([12.0]),
                       np.array([37.0]))  # fmt: skip
    polyline = PolylinePath(
        points=[(300, 150), (450, 150), (450, 250), (300, 250)], speed_mps=12.0, offset_m=37.0
    )
    for t in np.linspace(0.0, 60.0, 601):
        state, want = loops.at(float(t)), polyline.pose_at(float(t))
        # Exactly at a corner the two may pick adjacent sides: same place, other heading.
        assert math.hypot(state.x[0] - want.x, state.y[0] - want.y) < 1e-6
        if min(abs(want.x - 300), abs(want.x - 450), abs(want.y - 150), abs(want.y - 250)) > 0.5:
            assert state.vx[0] == want.vx and state.vy[0] == want.vy
            assert math.isclose(state.yaw[0], want.yaw, abs_tol=1e-12)


def test_scattered_loops_stay_in_the_square_at_town_speeds() -> None:
    loops = BlockLoops.scattered(256, 4000.0, 150.0, np.random.default_rng(7))
    group = np.arange(0, 256, 3)
    for t in (0.0, 13.7, 600.0):
        s = loops.at(t, group)
        assert len(s.x) == len(group)
        assert (s.x >= 0).all() and (s.x <= 4000).all() and (s.y >= 0).all() and (s.y <= 4000).all()
        speed = np.hypot(s.vx, s.vy)
        assert (speed >= MIN_SPEED_MPS).all() and (speed <= MAX_SPEED_MPS).all()
    # Spread over the map, not piled up: the egos occupy many distinct blocks.
    assert len({tuple(c) for c in loops.corners.tolist()}) > 150


def test_same_seed_same_swarm() -> None:
    a = BlockLoops.scattered(64, 2000.0, 150.0, np.random.default_rng(3)).at(5.0)
    b = BlockLoops.scattered(64, 2000.0, 150.0, np.random.default_rng(3)).at(5.0)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.yaw, b.yaw)
