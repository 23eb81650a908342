"""The authority's pose intake: poses wait in Zenoh's ring, the tick decodes them in batches.

With hundreds of egos at 50 Hz a Python callback per pose costs more than the pose's work:
every sample takes the GIL from the tick thread (which then waits up to the interpreter's
switch interval to get it back). So the pose subscriber has no Python callback: Zenoh puts
samples in a bounded ring (`RING_CAPACITY`; when full the oldest go first, which only
loses poses that newer ones of the same ego supersede), and the tick drains it once per
tick and decodes the whole batch with numpy.

Validation is the same as `messages.decode_pose`, row by row: 64 bytes, the layout version,
every value finite, the time in range; a key that is not `ego/<id>/pose[/<tile>]` of this
key space is refused too. Each bad sample is counted in `drops` under `pose` and dropped;
nothing raises into the tick. A pose's arrival time is the drain's time, at most one tick
after it arrived (the roster only judges it against seconds: skew and despawn timeout).
"""

from __future__ import annotations

from typing import Protocol

from carlaverse import messages as m
from carlaverse.fabric.guard import Tally
from carlaverse.keys import KeySpaceError, parse_cached

RING_CAPACITY = 32_768  # samples: 2.5 s of the session's largest roster (512 egos at 50 Hz)


class Sample(Protocol):
    """What the intake reads of a `zenoh.Sample`."""

    @property
    def key_expr(self) -> object: ...

    @property
    def payload(self) -> object: ...


class PoseRing(Protocol):
    def try_recv(self) -> Sample | None: ...


def decode_poses(payloads: list[bytes]) -> list[m.Pose | None]:
    """Each payload decoded as `messages.decode_pose` would, None where it would refuse."""
    out: list[m.Pose | None] = [None] * len(payloads)
    sized = [i for i, p in enumerate(payloads) if len(p) == m.POSE_SIZE]
    if sized:
        rows = m.decode_pose_rows(b"".join([payloads[i] for i in sized]))
        for i, pose in zip(sized, rows, strict=True):
            out[i] = pose
    return out


class PoseIntake:
    """Drains the pose ring: (node id, pose) of every good sample, in arrival order."""

    def __init__(self, ring: PoseRing, drops: Tally) -> None:
        self._ring = ring
        self._drops = drops

    def drain(self, limit: int = RING_CAPACITY) -> list[tuple[str, m.Pose]]:
        keys, payloads = take(self._ring, limit)
        out = []
        for key, pose in zip(keys, decode_poses(payloads), strict=True):
            node_id = pose_sender(key) if pose is not None else None
            if node_id is None:
                self._drops.add("pose")
            else:
                out.append((node_id, pose))
        return out


def take(ring: PoseRing, limit: int = RING_CAPACITY) -> tuple[list[str], list[bytes]]:
    """The keys and payloads of up to `limit` samples waiting in `ring`, oldest first."""
    keys, payloads = [], []
    recv = ring.try_recv
    while len(keys) < limit and (sample := recv()) is not None:
        keys.append(str(sample.key_expr))
        payloads.append(sample.payload.to_bytes())  # type: ignore[attr-defined]
    return keys, payloads


def pose_sender(key: str) -> str | None:
    """The node id of a pose key `ego/<id>/pose/<tile>` of this key space, else None."""
    try:
        parsed = parse_cached(key)
    except KeySpaceError:
        return None
    return parsed.node_id if parsed.area == "ego" and parsed.channel == "pose" else None
