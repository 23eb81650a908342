"""A node's pose source and its closing: the fabric's publisher thread may ask for a pose while
the node's thread frees the loop's blocks; it must get None, never read a closed block."""

from __future__ import annotations

import threading
import uuid

from carlaverse_nodes.drive.shared_state import CONTROL, STATE
from carlaverse_nodes.loop_host import LoopHost

from carlaverse.shm import SharedBlock


class _Ended:
    """A loop process that has already ended: `_stop_loop` only reaps it."""

    def join(self, timeout: float | None = None) -> None:
        pass


def _host_with_blocks() -> LoopHost:
    host = LoopHost(STATE, CONTROL, "test loop")
    name = f"cv-test-{uuid.uuid4().hex[:8]}"
    host._state = SharedBlock(f"{name}-state", STATE, create=True)
    host._control = SharedBlock(f"{name}-control", CONTROL, create=True)
    host._process, host._loop_summary = _Ended(), {"ticks": 1}
    return host


def test_after_the_blocks_are_freed_the_pose_source_says_none() -> None:
    host = _host_with_blocks()
    source = host.pose_source()
    assert source is not None and source(0.0) is None  # open, but the loop has not ticked
    host._stop_loop()
    assert source(0.0) is None  # before: the closed block's read raised TypeError


def test_a_pose_source_reading_while_the_node_closes_never_fails() -> None:
    host = _host_with_blocks()
    source = host.pose_source()
    assert source is not None
    failures: list[BaseException] = []
    closing = threading.Event()

    def publisher() -> None:  # the fabric's publisher thread, asking as fast as it can
        while True:
            try:
                source(0.0)
            except BaseException as exc:  # any failure is the finding
                failures.append(exc)
                return
            if closing.is_set() and host._state is None:
                return

    thread = threading.Thread(target=publisher)
    thread.start()
    closing.set()
    host._stop_loop()
    thread.join(5)
    assert not thread.is_alive() and failures == []
