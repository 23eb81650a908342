"""A receiver's record of what arrived: one-way latency per measured pose, counted once.

Called from whatever thread the transport delivers on (a Zenoh callback, a socket thread, a
DDS wait loop); a list append and a set insert are atomic under the GIL, so no lock is taken
on that path. The arrival is stamped after the pose was decoded, with the same clock
(CLOCK_MONOTONIC) the publisher stamped it with.
"""

from __future__ import annotations

import time
from typing import Any

from carlaverse.messages import MessageError, Pose, decode_pose
from peers.transport import WARM_UP


class Arrivals:
    """What one receiver process saw; `counter[slot]` tells the parent how far it got."""

    def __init__(self, warmed: Any, counter: Any, slot: int) -> None:
        self.latencies_s: list[float] = []
        self.seen: set[int] = set()
        self.duplicates = 0
        self.malformed = 0
        self._warmed = warmed  # an Event: set once anything from the publisher arrived
        self._counter = counter  # a shared array of measured arrivals, one slot per receiver
        self._slot = slot

    def payload(self, payload: bytes | bytearray | memoryview) -> None:
        try:
            pose = decode_pose(payload)
        except MessageError:
            self.malformed += 1
            return
        self.pose(pose)

    def pose(self, pose: Pose) -> None:
        latency_s = time.monotonic() - pose.t
        if pose.flags & WARM_UP:
            if not self._warmed.is_set():
                self._warmed.set()
            return
        index = int(pose.vz)  # the bench index (peers.transport.sample)
        if index in self.seen:
            self.duplicates += 1
            return
        self.seen.add(index)
        self.latencies_s.append(latency_s)
        self._counter[self._slot] = len(self.seen)

    def summary(self) -> dict[str, Any]:
        return {
            "latencies_s": self.latencies_s,
            "received": len(self.seen),
            "duplicates": self.duplicates,
            "malformed": self.malformed,
        }
