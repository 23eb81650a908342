"""Every remote ego's stream as columns: what a node keeps per pose, without an object per pose.

A node hearing a whole session of 256 egos receives 12,800 poses a second. Applied one at a
time (the checks, the sender's statistics, the actor's sample buffer: Python calls per pose)
that cost more than Zenoh's own receive. So the world view applies everything that arrived
since its last update in one pass over arrays (`EgoStreams.apply`): the checks, each sender's
statistics, and each sender's recent samples written into a ring of its own. A sender's
`RemoteActor` takes its samples from the ring only when it is read (`EgoActors`): a view that
is drawn pays per pose only for the actors it draws, one that never draws (`carlaverse stats`,
the launcher's presence watch, a recorder) builds no Python object per pose at all.

Each update's poses are applied together, so one sender can have several rows in one batch
(a late update); those are applied in rounds, each sender's rows in the order they came.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from itertools import chain, repeat
from typing import NamedTuple

import numpy as np
from msgspec.structs import astuple

from carlaverse.fabric.remote_actor import InterpolationSettings, RemoteActor
from carlaverse.fabric.stream_summary import StreamSummary
from carlaverse.messages import Pose, PoseColumns, pose_columns
from carlaverse.support.stats import percentile

RING = 64  # samples kept per sender for its actor: 1.28 s at 50 Hz, longer than any delay
WINDOW = 1024  # samples per sender in its latency statistics: 20 s at 50 Hz
JITTER_GAIN = 1 / 16  # RFC 3550 interarrival jitter


class Batch(NamedTuple):
    """Poses received together, one row each: who sent it, its columns, when it arrived."""

    ids: list[str]
    columns: PoseColumns
    rx_t: np.ndarray  # [s] session time of arrival, float64


class Applied(NamedTuple):
    absent: int  # rows from a sender with no presence (or this node itself)
    implausible: int  # rows whose time is too far from session time
    fresh: np.ndarray  # the slots that have a sample newer than any before


def batch_of_poses(ids: list[str], poses: list[Pose], rx_t: list[float]) -> Batch:
    """Poses received one at a time, as a batch (one array built from all of them)."""
    # one flat pass over every field (seq, t, ..., az, flags: the struct's order), the fastest
    # of the ways measured (a list of tuples into np.array took 1.6 times as long)
    flat = chain.from_iterable(map(astuple, poses))
    table = np.fromiter(flat, np.float64, len(poses) * 18).reshape(len(poses), 18)
    # a sequence number is a u32 on the wire: exact in float64
    seq, flags = table[:, 0].astype(np.int64), table[:, 17].astype(np.int64)
    columns = PoseColumns(seq, table[:, 1:17], flags)
    return Batch(ids, columns, np.asarray(rx_t, dtype=np.float64))


def batch_of_wire(ids: list[str], payloads: list[bytes], rx_t: list[float]) -> Batch:
    """Wire poses received one at a time, already checked (`messages.check_pose`), as a batch:
    the bytes joined and read as columns in one numpy pass, no `Pose` built for any."""
    columns, _ = pose_columns(b"".join(payloads))  # every row passed `check_pose` already
    return Batch(ids, columns, np.asarray(rx_t, dtype=np.float64))


def batch_of_digests(
    ids: list[list[str]], rows: list[bytes], rx_t: list[float]
) -> tuple[Batch, int]:
    """Digests' rows (each digest's ids and its consecutive 64-byte poses), as one batch of
    the rows `decode_pose` would accept, and how many it would refuse: every digest an update
    drains is checked and turned into columns in one numpy pass."""
    columns, good = pose_columns(b"".join(rows))
    senders = list(chain.from_iterable(ids))
    arrived = np.repeat(np.asarray(rx_t, dtype=np.float64), [len(i) for i in ids])
    if good.all():  # nearly always
        return Batch(senders, columns, arrived), 0
    keep = np.flatnonzero(good)
    kept = Batch([senders[k] for k in keep.tolist()], columns.take(keep), arrived[keep])
    return kept, len(senders) - len(keep)


def join_batches(batches: list[Batch]) -> Batch:
    if len(batches) == 1:
        return batches[0]
    ids = [i for b in batches for i in b.ids]
    parts = zip(*(b.columns for b in batches), strict=True)
    columns = PoseColumns(*(np.concatenate(part) for part in parts))
    return Batch(ids, columns, np.concatenate([b.rx_t for b in batches]))


class EgoStreams:
    """Per-sender state in columns, one row (a slot) per sender. Not thread-safe: one owner.

    A sender gets a slot when it becomes present (`admit`); rows from ids without an admitted
    slot are refused before anything is kept for them, so an intruder's poses grow nothing.
    """

    admitted: np.ndarray
    active: np.ndarray
    last_t: np.ndarray
    last_rx: np.ndarray
    count: np.ndarray
    first_seq: np.ndarray
    max_seq: np.ndarray
    jitter: np.ndarray
    last_transit: np.ndarray
    stat_pos: np.ndarray
    latency: np.ndarray
    arrived: np.ndarray
    ring_pos: np.ndarray
    ring_floor: np.ndarray
    ring_values: np.ndarray
    ring_seq: np.ndarray
    ring_flags: np.ndarray
    ring_rx: np.ndarray

    def __init__(self, own_id: str, settings: InterpolationSettings, capacity: int = 64) -> None:
        self.s = settings
        self.index: dict[str, int] = {}
        self.ids: list[str] = []
        self._cap = 0
        self._grow(capacity)
        # This node's own id holds slot 0, never admitted: a digest carries our own pose too,
        # and that row is skipped, not counted as refused.
        self._own = 0
        self._new_slot(own_id, 1)

    # name: (fill, dtype, shape of one slot's entry)
    _COLUMNS: dict[str, tuple[float, type, tuple[int, ...]]] = {
        "admitted": (False, bool, ()),  # present: its poses count
        "active": (False, bool, ()),  # the view holds an actor for it
        "last_t": (-np.inf, np.float64, ()),  # newest sample's time
        "last_rx": (-np.inf, np.float64, ()),  # newest arrival
        "count": (0, np.int64, ()),
        "first_seq": (-1, np.int64, ()),
        "max_seq": (-1, np.int64, ()),
        "jitter": (0.0, np.float64, ()),
        "last_transit": (np.nan, np.float64, ()),
        "stat_pos": (0, np.int64, ()),  # samples ever counted into the statistics window
        "latency": (0.0, np.float64, (WINDOW,)),
        "arrived": (0.0, np.float64, (WINDOW,)),
        "ring_pos": (0, np.int64, ()),  # samples ever written into the ring
        "ring_floor": (0, np.int64, ()),  # where the current actor's samples start
        "ring_values": (0.0, np.float64, (RING, 16)),
        "ring_seq": (0, np.int64, (RING,)),
        "ring_flags": (0, np.int64, (RING,)),
        "ring_rx": (0.0, np.float64, (RING,)),
    }

    def _grow(self, cap: int) -> None:
        n = len(self.ids)
        for name, (fill, dtype, shape) in self._COLUMNS.items():
            column = np.full((cap, *shape), fill, dtype=dtype)
            if self._cap:
                column[:n] = getattr(self, name)[:n]
            setattr(self, name, column)
        self._cap = cap

    # ------------------------------------------------------------ senders

    def admit(self, node_id: str, limit: int) -> None:
        """`node_id` is present: its poses count. Beyond `limit` senders, the slot of one that
        is no longer present is reused (its statistics go)."""
        slot = self.index.get(node_id)
        if slot == self._own:
            return
        if slot is None:
            slot = self._new_slot(node_id, limit)
        self.admitted[slot] = True

    def refuse(self, node_id: str) -> None:
        """`node_id` left or is tombstoned: its poses no longer count (its statistics stay)."""
        slot = self.index.get(node_id)
        if slot is not None:
            self.admitted[slot] = False

    def _new_slot(self, node_id: str, limit: int) -> int:
        if len(self.ids) >= limit:
            n = len(self.ids)  # slot 0 is our own, never reused
            gone = np.flatnonzero(~self.admitted[1:n] & ~self.active[1:n])
            if len(gone):
                slot = int(gone[0]) + 1
                del self.index[self.ids[slot]]
                self.ids[slot] = node_id
                self.index[node_id] = slot
                self._clear(slot)
                return slot
        if len(self.ids) == self._cap:
            self._grow(2 * self._cap)
        slot = len(self.ids)
        self.ids.append(node_id)
        self.index[node_id] = slot
        return slot

    def _clear(self, slot: int) -> None:
        self.last_t[slot] = self.last_rx[slot] = -np.inf
        self.reset_statistics(slot)
        self.ring_floor[slot] = self.ring_pos[slot]

    def reset_statistics(self, slot: int) -> None:
        self.count[slot] = self.stat_pos[slot] = 0
        self.first_seq[slot] = self.max_seq[slot] = -1
        self.jitter[slot] = 0.0
        self.last_transit[slot] = np.nan

    # ------------------------------------------------------------ poses

    def apply(self, batch: Batch) -> Applied:
        """Check a batch and keep what passes (module docstring)."""
        slots = np.array(list(map(self.index.get, batch.ids, repeat(-1))), dtype=np.int64)
        values, rx = batch.columns.values, batch.rx_t
        admitted = (slots >= 0) & self.admitted[np.maximum(slots, 0)]
        plausible = np.abs(values[:, 0] - rx) <= self.s.implausible_s
        rows = np.flatnonzero(admitted & plausible)
        fresh = [np.empty(0, np.int64)]
        while len(rows):
            if np.bincount(slots[rows]).max() == 1:  # nearly always: every sender once
                fresh.append(self._round(slots[rows], batch.columns, rows, rx[rows]))
                break
            # a round takes every sender's first remaining row, so no slot twice in a round
            _, first = np.unique(slots[rows], return_index=True)
            first.sort()
            now = rows[first]
            fresh.append(self._round(slots[now], batch.columns, now, rx[now]))
            rows = np.delete(rows, first)
        return Applied(
            int(np.count_nonzero(~admitted & (slots != self._own))),
            int(np.count_nonzero(admitted & ~plausible)),
            np.unique(np.concatenate(fresh)),
        )

    def _round(
        self, s: np.ndarray, columns: PoseColumns, rows: np.ndarray, rx: np.ndarray
    ) -> np.ndarray:
        """Apply rows of distinct senders `s`; return the senders that got a newer sample."""
        t = columns.values[rows, 0]
        seq = columns.seq[rows]
        # statistics: every plausible sample of a present sender, late or not
        transit = rx - t
        last = self.last_transit[s]
        jitter = self.jitter[s]
        step = (np.abs(transit - last) - jitter) * JITTER_GAIN
        self.jitter[s] = np.where(np.isnan(last), jitter, jitter + step)
        self.last_transit[s] = transit
        at = self.stat_pos[s] % WINDOW
        self.latency[s, at] = transit
        self.arrived[s, at] = rx
        self.stat_pos[s] += 1
        self.count[s] += 1
        first = self.first_seq[s]
        self.first_seq[s] = np.where(first < 0, seq, first)
        self.max_seq[s] = np.maximum(self.max_seq[s], seq)
        self.last_rx[s] = np.maximum(self.last_rx[s], rx)
        # the ring: only samples newer than the sender's newest (Zenoh keeps a sender's order;
        # an older one is a duplicate, or came late through another path, and is not drawn)
        newer = t > self.last_t[s]
        if not newer.all():
            s, t, rows, rx = s[newer], t[newer], rows[newer], rx[newer]
        at = self.ring_pos[s] % RING
        self.ring_values[s, at] = columns.values[rows]
        self.ring_seq[s, at] = columns.seq[rows]
        self.ring_flags[s, at] = columns.flags[rows]
        self.ring_rx[s, at] = rx
        self.ring_pos[s] += 1
        self.last_t[s] = t
        return s

    def samples_since(self, slot: int, position: int) -> tuple[list[Pose], list[float]]:
        """The samples of `slot` from ring `position` on (at most `RING`), oldest first."""
        end = int(self.ring_pos[slot])
        start = max(position, int(self.ring_floor[slot]), end - RING)
        if start >= end:
            return [], []
        at = np.arange(start, end) % RING
        kept = PoseColumns(self.ring_seq[slot, at], self.ring_values[slot, at],
                           self.ring_flags[slot, at])  # fmt: skip
        return kept.poses(), self.ring_rx[slot, at].tolist()

    def summary(self, slot: int, now: float) -> StreamSummary:
        n = min(int(self.stat_pos[slot]), WINDOW)
        pos = int(self.stat_pos[slot])
        latency = self.latency[slot, :n].tolist()
        oldest = self.arrived[slot, pos % WINDOW if pos > WINDOW else 0]
        newest = self.arrived[slot, (pos - 1) % WINDOW]
        span = float(newest - oldest) if n > 1 else 0.0
        rate = (n - 1) / span if span > 0 else 0.0
        count, first = int(self.count[slot]), int(self.first_seq[slot])
        expected = int(self.max_seq[slot]) - first + 1 if first >= 0 else 0
        loss = max(0.0, 1 - count / expected) if expected > 0 else 0.0
        return StreamSummary(
            samples=count,
            rate_hz=round(rate, 2),
            latency_p50_ms=round(percentile(latency, 0.5) * 1e3, 3),
            latency_p99_ms=round(percentile(latency, 0.99) * 1e3, 3),
            jitter_ms=round(float(self.jitter[slot]) * 1e3, 3),
            loss=round(loss, 4),
            last_seen_s=round(now - float(self.last_rx[slot]), 3),
        )


class SenderStats:
    """One sender's statistics as a node sees them (a view into `EgoStreams`)."""

    def __init__(self, streams: EgoStreams, slot: int) -> None:
        self._streams, self._slot = streams, slot

    @property
    def count(self) -> int:
        return int(self._streams.count[self._slot])

    def summary(self, now: float) -> StreamSummary:
        return self._streams.summary(self._slot, now)


class StreamStatsTable(Mapping[str, SenderStats]):
    """Every sender with statistics (a sample counted since it was last reset), by id."""

    def __init__(self, streams: EgoStreams) -> None:
        self._streams = streams

    def _slot(self, node_id: str) -> int | None:
        slot = self._streams.index.get(node_id)
        return slot if slot is not None and self._streams.count[slot] > 0 else None

    def __getitem__(self, node_id: str) -> SenderStats:
        slot = self._slot(node_id)
        if slot is None:
            raise KeyError(node_id)
        return SenderStats(self._streams, slot)

    def __contains__(self, node_id: object) -> bool:
        return isinstance(node_id, str) and self._slot(node_id) is not None

    def __iter__(self) -> Iterator[str]:
        ids, count = self._streams.ids, self._streams.count
        return iter([ids[k] for k in np.flatnonzero(count[: len(ids)] > 0).tolist()])

    def __len__(self) -> int:
        return int(np.count_nonzero(self._streams.count[: len(self._streams.ids)] > 0))


class EgoActors(Mapping[str, RemoteActor]):
    """The view's remote egos by id; each takes its new samples from its ring when read."""

    def __init__(self, streams: EgoStreams, settings: InterpolationSettings) -> None:
        self._streams = streams
        self.settings = settings
        self._actors: dict[str, RemoteActor] = {}
        self._fed: dict[str, int] = {}  # ring position each actor has taken samples up to

    def open(self, node_id: str) -> RemoteActor:
        """Start an actor for `node_id`, fed from the samples its slot holds from now on."""
        slot = self._streams.index[node_id]
        actor = self._actors[node_id] = RemoteActor(node_id, self.settings)
        self._fed[node_id] = int(self._streams.ring_floor[slot])
        self._streams.active[slot] = True
        return actor

    def close(self, node_id: str) -> RemoteActor | None:
        actor = self._actors.pop(node_id, None)
        if actor is not None:
            del self._fed[node_id]
            slot = self._streams.index[node_id]
            self._streams.active[slot] = False
            # the samples so far were this actor's: a next actor for the id starts after them
            self._streams.ring_floor[slot] = self._streams.ring_pos[slot]
        return actor

    def __getitem__(self, node_id: str) -> RemoteActor:
        actor = self._actors[node_id]
        streams = self._streams
        slot = streams.index[node_id]
        fed = self._fed[node_id]
        if streams.ring_pos[slot] > fed:
            poses, rx = streams.samples_since(slot, fed)
            for pose, rx_t in zip(poses, rx, strict=True):
                actor.add(pose, rx_t)
            self._fed[node_id] = int(streams.ring_pos[slot])
        return actor

    def __contains__(self, node_id: object) -> bool:
        return node_id in self._actors

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._actors))

    def __len__(self) -> int:
        return len(self._actors)
