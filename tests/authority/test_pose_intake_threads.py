"""The authority's pose ring has two readers, the digest relay and the tick, in turn.

While the digest is heard the relay reads the ring and the tick takes what it hands over;
when the digest's last listener goes (or the first comes) the two swap, and for a moment
both may be reading. No pose may be lost or taken twice in a swap, and neither reader may
fail. Here a real Zenoh ring is fed while the relay switches on and off as fast as it can.
"""

from __future__ import annotations

import threading
import time

import pytest
import zenoh

from carlaverse.authority.pose_intake import RING_CAPACITY, PoseIntake
from carlaverse.keys import Keys
from carlaverse.messages import Pose, encode_pose
from carlaverse.support.tally import Tally
from carlaverse.transport.session import FabricSettings, open_session

EGOS = 8
SWAPS = 3_000  # relay on, take, off: each a moment where both readers could meet
DEADLINE_S = 60.0


@pytest.mark.timeout(120)
def test_the_relay_and_the_tick_swap_the_ring_without_meeting_or_losing_a_pose() -> None:
    session = open_session(FabricSettings(connect=[], listen=["tcp/127.0.0.1:0"]))
    keys = Keys("intake-race")
    ring = session.declare_subscriber(
        keys.all_ego("pose"), zenoh.handlers.RingChannel(RING_CAPACITY)
    )
    publishers = [session.declare_publisher(keys.pose(f"e{i}", "t0_0")) for i in range(EGOS)]
    drops = Tally()
    intake = PoseIntake(ring, drops)
    stop = threading.Event()
    errors: list[BaseException] = []
    sent = [0]
    taken: list[tuple[str, Pose]] = []

    def guarded(work: object) -> threading.Thread:
        def run() -> None:
            try:
                work()  # type: ignore[operator]
            except BaseException as exc:  # the test reads it; the thread must not hide it
                errors.append(exc)
                stop.set()

        return threading.Thread(target=run, daemon=True)

    def feed() -> None:
        seq = 0
        while not stop.is_set():
            seq += 1
            for i, publisher in enumerate(publishers):
                publisher.put(encode_pose(Pose(seq, 100.0 + seq * 0.02, float(i), 0.0)))
                sent[0] += 1

    def relay() -> None:  # as `PoseDigestRelay.step` and `_follow` do, swapped on and off
        for _ in range(SWAPS):
            if stop.is_set():
                return
            intake.relayed = True
            intake.relay_take()
            intake.relayed = False

    def tick() -> None:
        while not stop.is_set():
            taken.extend(intake.drain())

    feeder, relayer, ticker = guarded(feed), guarded(relay), guarded(tick)
    for thread in (feeder, relayer, ticker):
        thread.start()
    relayer.join(DEADLINE_S)
    stop.set()
    feeder.join(10)
    ticker.join(10)
    try:
        assert not errors, errors
        assert not relayer.is_alive(), f"the relay did not finish {SWAPS} swaps in time"
        deadline = time.monotonic() + 10
        while len(taken) < sent[0] and time.monotonic() < deadline:  # what is still in the ring
            taken.extend(intake.drain())
        assert dict(drops) == {}, dict(drops)
        assert len(taken) == sent[0], (len(taken), sent[0])
        # Each ego's poses arrive once each, in the order they were put.
        for i in range(EGOS):
            seqs = [pose.seq for node_id, pose in taken if node_id == f"e{i}"]
            assert seqs == sorted(set(seqs)), f"e{i}: poses lost, doubled or reordered"
    finally:
        ring.undeclare()
        session.close()
