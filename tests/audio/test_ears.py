"""The live node's ears from its shared state: a car's head and own engine, a walker's
tracked head, and a node's published pose when it has no block."""

from __future__ import annotations

import uuid
from multiprocessing import resource_tracker

import numpy as np
import pytest

from carlaverse import messages as m
from carlaverse.audio.config import ListenerConfig
from carlaverse.audio.ears import OWN_ENGINE_ID, BlockSpec, Ears
from carlaverse.shm import SharedBlock, new_record

CAR = np.dtype([("t", "<f8"), ("x", "<f8"), ("y", "<f8"), ("yaw", "<f8"), ("vx", "<f8"),
                ("vy", "<f8"), ("rpm", "<f8"), ("throttle", "<f8"), ("running", "u1")])  # fmt: skip
WALKER = np.dtype([("t", "<f8"), ("x", "<f8"), ("y", "<f8"), ("eye_z", "<f8"), ("yaw", "<f8"),
                   ("pitch", "<f8"), ("roll", "<f8"), ("vx", "<f8"), ("vy", "<f8"),
                   ("running", "u1")])  # fmt: skip


def attached(ears: Ears, block: SharedBlock) -> Ears:
    """Let `ears` attach, then give the block back to this process's resource tracker: an
    attaching reader unregisters the name (it is meant to be another process), and the
    writer's unlink would then make the tracker print a KeyError."""
    ears.listener(0.0)
    resource_tracker.register(block._shm._name, "shared_memory")
    return ears


def written(dtype: np.dtype, **values: float) -> SharedBlock:
    block = SharedBlock(f"cv-test-{uuid.uuid4().hex[:8]}", dtype, create=True)
    record = new_record(dtype)
    for name, value in values.items():
        record[name] = value
    block.write(record)
    return block


def test_a_car_is_heard_from_its_drivers_head_with_its_own_engine() -> None:
    config = ListenerConfig(head_offset_m=(0.2, 0.35, 1.2), engine_offset_m=(1.6, 0.0, 0.6))
    block = written(CAR, x=10.0, y=5.0, yaw=np.pi / 2, vx=0.0, vy=8.0, rpm=2500.0,
                    throttle=0.6, running=1)  # fmt: skip
    ears = attached(Ears(config, BlockSpec(block.name, CAR)), block)
    try:
        listener = ears.listener(3.0)
        # Facing north: forward is +y, left is −x.
        assert listener.position == pytest.approx([10.0 - 0.35, 5.0 + 0.2, 1.2])
        assert listener.rotation[:, 0] == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)
        assert listener.velocity == pytest.approx([0.0, 8.0, 0.0])
        (engine,) = ears.own_emitters(3.0)
        assert engine.id == OWN_ENGINE_ID and engine.kind == "engine"
        assert (engine.x, engine.y, engine.z) == pytest.approx((10.0, 6.6, 0.6))
        assert engine.drive_a == 2500.0 and engine.drive_b == pytest.approx(0.6)
        assert (engine.vx, engine.vy) == (0.0, 8.0)
    finally:
        ears.close()
        block.close()


def test_a_walker_is_heard_from_its_tracked_head() -> None:
    block = written(WALKER, x=1.0, y=2.0, eye_z=1.65, yaw=0.0, pitch=0.0, roll=0.3, running=1)
    ears = attached(Ears(ListenerConfig(), BlockSpec(block.name, WALKER)), block)
    try:
        listener = ears.listener(0.0)
        assert listener.position == pytest.approx([1.0, 2.0, 1.65])
        # Rolled 0.3 rad to the right about the forward axis: the left ear goes up.
        left = listener.rotation[:, 1]
        assert left == pytest.approx([0.0, np.cos(0.3), np.sin(0.3)])
        assert ears.own_emitters(0.0) == []  # no powertrain
    finally:
        ears.close()
        block.close()


def test_before_the_loop_runs_and_without_a_block() -> None:
    block = written(CAR, x=1.0, running=0)
    ears = attached(Ears(ListenerConfig(), BlockSpec(block.name, CAR)), block)
    try:
        assert ears.listener(0.0) is None and ears.own_emitters(0.0) == []
    finally:
        ears.close()
        block.close()
    published = Ears(ListenerConfig(head_offset_m=(0.0, 0.0, 1.5)), None)
    assert published.listener(0.0) is None
    published.pose = m.Pose(1, 0.0, 4.0, -3.0, yaw=0.0)
    assert published.listener(0.0).position == pytest.approx([4.0, -3.0, 1.5])
