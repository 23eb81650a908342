"""Every remote ego's stream: what a node keeps per sender, and per pose only what it must.

A node hears every pose of every ego near it (a whole session of 256 egos: 12,800 a second).
The world view decodes the poses an update drains once (`messages.decode_pose_rows`) and
hands the decoded `Pose`s here (`EgoStreams.apply`), where each is checked (present sender,
plausible time), counted into its sender's statistics and, if newer than the sender's newest,
kept in a ring of the sender's recent samples. A sender's `RemoteActor` takes its samples
from the ring only when it is read (`EgoActors`): a view that is drawn pays the actor's work
only for the actors it draws, one that never draws (`carlaverse stats`, the launcher's
presence watch, a recorder) keeps the decoded pose and nothing more.

Plain Python per pose, not arrays: a node's loop applies a few poses per update (one, for a
node hearing one ego at the loop's own rate), and numpy's setup per array operation cost
dozens of microseconds per update there, more than Zenoh's whole receive.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator, Mapping
from itertools import islice
from typing import NamedTuple

from carlaverse.messages import Pose
from carlaverse.support.stats import percentile
from carlaverse.world.remote_actor import InterpolationSettings, RemoteActor
from carlaverse.world.stream_summary import StreamSummary

RING = 64  # samples kept per sender for its actor: 1.28 s at 50 Hz, longer than any delay
WINDOW = 1024  # samples per sender in its latency statistics: 20 s at 50 Hz
JITTER_GAIN = 1 / 16  # RFC 3550 interarrival jitter
# [s] A sample this much older than its sender's newest starts the sender's stream over: Zenoh
# keeps a sender's order, so it is no late duplicate but a new timeline (a looping replay's
# next pass starts at the recording's beginning again, announced as a new authority).
NEW_TIMELINE_S = 1.0


class Applied(NamedTuple):
    absent: int  # poses from a sender with no presence
    implausible: int  # poses whose time is too far from session time
    opened: list[str]  # senders without an actor that now have a sample newer than any before
    restarted: list[str] = []  # senders whose stream started over on a new timeline


class SenderStream:
    """One sender's statistics and recent samples. Not thread-safe: one owner."""

    __slots__ = (
        "active", "admitted", "arrived", "count", "first_seq", "jitter", "last_rx", "last_t",
        "last_transit", "latency", "max_seq", "node_id", "ring", "ring_floor", "ring_pos",
    )  # fmt: skip

    def __init__(self, node_id: str) -> None:
        self.node_id = node_id
        self.admitted = False  # present: its poses count
        self.active = False  # the view holds an actor for it
        self.last_t = -math.inf  # [s] newest sample's time
        self.last_rx = -math.inf  # [s] newest arrival
        self.latency: deque[float] = deque(maxlen=WINDOW)  # [s] one-way, newest last
        self.arrived: deque[float] = deque(maxlen=WINDOW)  # [s] arrival times, newest last
        self.ring: deque[tuple[Pose, float]] = deque(maxlen=RING)  # (sample, arrival)
        self.ring_pos = 0  # samples ever kept in the ring
        self.ring_floor = 0  # where the current actor's samples start
        self.reset_statistics()

    def reset_statistics(self) -> None:
        self.count = 0
        self.first_seq = self.max_seq = -1
        self.jitter = 0.0  # [s]
        self.last_transit = math.nan  # [s]
        self.latency.clear()
        self.arrived.clear()

    def clear(self) -> None:
        """Forget the former owner of this id's place: its times, statistics and samples."""
        self.last_t = self.last_rx = -math.inf
        self.reset_statistics()
        self.ring_floor = self.ring_pos

    def take(self, pose: Pose, rx_t: float) -> bool:
        """Count a plausible sample of this present sender; keep it if it is newer than the
        newest (Zenoh keeps a sender's order: an older one is a duplicate, or came late
        through another path, and is not drawn). True when it was kept."""
        t = pose.t
        transit = rx_t - t
        last = self.last_transit
        if last == last:  # not NaN: a transit before this one
            self.jitter += (abs(transit - last) - self.jitter) * JITTER_GAIN
        self.last_transit = transit
        self.latency.append(transit)
        self.arrived.append(rx_t)
        self.count += 1
        seq = pose.seq
        if self.first_seq < 0:
            self.first_seq = seq
        if seq > self.max_seq:
            self.max_seq = seq
        if rx_t > self.last_rx:
            self.last_rx = rx_t
        if t <= self.last_t:
            return False
        self.last_t = t
        self.ring.append((pose, rx_t))
        self.ring_pos += 1
        return True

    @property
    def newest(self) -> Pose | None:
        """The newest sample kept (None before any)."""
        return self.ring[-1][0] if self.ring else None

    def samples_since(self, position: int) -> Iterator[tuple[Pose, float]]:
        """The kept samples from ring `position` on (at most `RING`), oldest first."""
        oldest = self.ring_pos - len(self.ring)
        start = max(position, self.ring_floor, oldest)
        return islice(self.ring, start - oldest, None)

    def summary(self, now: float) -> StreamSummary:
        latency, arrived = list(self.latency), self.arrived
        n = len(latency)
        span = arrived[-1] - arrived[0] if n > 1 else 0.0
        rate = (n - 1) / span if span > 0 else 0.0
        expected = self.max_seq - self.first_seq + 1 if self.first_seq >= 0 else 0
        loss = max(0.0, 1 - self.count / expected) if expected > 0 else 0.0
        return StreamSummary(
            samples=self.count,
            rate_hz=round(rate, 2),
            latency_p50_ms=round(percentile(latency, 0.5) * 1e3, 3),
            latency_p99_ms=round(percentile(latency, 0.99) * 1e3, 3),
            jitter_ms=round(self.jitter * 1e3, 3),
            loss=round(loss, 4),
            last_seen_s=round(now - self.last_rx, 3),
        )


class EgoStreams(Mapping[str, SenderStream]):
    """Every sender's stream by id. Not thread-safe: one owner (the world view).

    A sender gets a stream when it becomes present (`admit`); poses from ids without an
    admitted stream are refused before anything is kept for them, so an intruder's poses grow
    nothing. This node's own poses (a digest carries them too) are skipped, not counted.
    """

    def __init__(self, own_id: str, settings: InterpolationSettings) -> None:
        self.s = settings
        self.own_id = own_id
        self._streams: dict[str, SenderStream] = {}

    def __getitem__(self, node_id: str) -> SenderStream:
        return self._streams[node_id]

    def __iter__(self) -> Iterator[str]:
        return iter(self._streams)

    def __len__(self) -> int:
        return len(self._streams)

    # ------------------------------------------------------------ senders

    def admit(self, node_id: str, limit: int) -> None:
        """`node_id` is present: its poses count. Beyond `limit` senders, the place of one that
        is no longer present is reused (its statistics go)."""
        if node_id == self.own_id:
            return
        stream = self._streams.get(node_id)
        if stream is None:
            stream = self._new_stream(node_id, limit)
        stream.admitted = True

    def refuse(self, node_id: str) -> None:
        """`node_id` left or is tombstoned: its poses no longer count (its statistics stay)."""
        stream = self._streams.get(node_id)
        if stream is not None:
            stream.admitted = False

    def _new_stream(self, node_id: str, limit: int) -> SenderStream:
        if len(self._streams) >= limit:
            gone = next((k for k, s in self._streams.items() if not (s.admitted or s.active)), None)
            if gone is not None:
                del self._streams[gone]
        stream = self._streams[node_id] = SenderStream(node_id)
        return stream

    # ------------------------------------------------------------ poses

    def apply(self, ids: list[str], poses: list[Pose], rx_t: list[float]) -> Applied:
        """Check decoded poses and keep what passes (module docstring), in arrival order."""
        streams, own, limit_s = self._streams, self.own_id, self.s.implausible_s
        absent = implausible = 0
        opened: list[str] = []
        restarted: list[str] = []
        for node_id, pose, rx in zip(ids, poses, rx_t, strict=True):
            stream = streams.get(node_id)
            if stream is None or not stream.admitted:
                absent += node_id != own
                continue
            if abs(pose.t - rx) > limit_s:
                implausible += 1
                continue
            if pose.t < stream.last_t - NEW_TIMELINE_S:
                stream.clear()  # its samples from here on are the new timeline's
                restarted.append(node_id)
            if stream.take(pose, rx) and not stream.active and node_id not in opened:
                opened.append(node_id)
        return Applied(absent, implausible, opened, restarted)

    def silent(self, now: float, timeout_s: float) -> list[str]:
        """The senders with an actor that have not been heard for longer than `timeout_s`."""
        return [k for k, s in self._streams.items() if s.active and now - s.last_rx > timeout_s]


class SenderStats:
    """One sender's statistics as a node sees them (a view into its `SenderStream`)."""

    def __init__(self, stream: SenderStream) -> None:
        self._stream = stream

    @property
    def count(self) -> int:
        return self._stream.count

    def summary(self, now: float) -> StreamSummary:
        return self._stream.summary(now)


class StreamStatsTable(Mapping[str, SenderStats]):
    """Every sender with statistics (a sample counted since it was last reset), by id."""

    def __init__(self, streams: EgoStreams) -> None:
        self._streams = streams

    def _counted(self, node_id: str) -> SenderStream | None:
        stream = self._streams.get(node_id)
        return stream if stream is not None and stream.count > 0 else None

    def __getitem__(self, node_id: str) -> SenderStats:
        stream = self._counted(node_id)
        if stream is None:
            raise KeyError(node_id)
        return SenderStats(stream)

    def __contains__(self, node_id: object) -> bool:
        return isinstance(node_id, str) and self._counted(node_id) is not None

    def __iter__(self) -> Iterator[str]:
        return iter([k for k, s in self._streams.items() if s.count > 0])

    def __len__(self) -> int:
        return sum(1 for s in self._streams.values() if s.count > 0)


class EgoActors(Mapping[str, RemoteActor]):
    """The view's remote egos by id; each takes its new samples from its ring when read."""

    def __init__(self, streams: EgoStreams, settings: InterpolationSettings) -> None:
        self._streams = streams
        self.settings = settings
        self._actors: dict[str, RemoteActor] = {}
        self._fed: dict[str, int] = {}  # ring position each actor has taken samples up to

    def open(self, node_id: str) -> RemoteActor:
        """Start an actor for `node_id`, fed from the samples its stream keeps from now on."""
        stream = self._streams[node_id]
        actor = self._actors[node_id] = RemoteActor(node_id, self.settings)
        self._fed[node_id] = stream.ring_floor
        stream.active = True
        return actor

    def restart(self, node_id: str) -> None:
        """A new actor for `node_id` whose stream started over: fed from the new start."""
        if node_id in self._actors:
            self._actors[node_id] = RemoteActor(node_id, self.settings, self._actors[node_id].kind)
            self._fed[node_id] = self._streams[node_id].ring_floor

    def close(self, node_id: str) -> RemoteActor | None:
        actor = self._actors.pop(node_id, None)
        if actor is not None:
            del self._fed[node_id]
            stream = self._streams[node_id]
            stream.active = False
            # the samples so far were this actor's: a next actor for the id starts after them
            stream.ring_floor = stream.ring_pos
        return actor

    def __getitem__(self, node_id: str) -> RemoteActor:
        actor = self._actors[node_id]
        stream = self._streams[node_id]
        if stream.ring_pos > self._fed[node_id]:
            for pose, rx_t in stream.samples_since(self._fed[node_id]):
                actor.add(pose, rx_t)
            self._fed[node_id] = stream.ring_pos
        return actor

    def __contains__(self, node_id: object) -> bool:
        return node_id in self._actors

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._actors))

    def __len__(self) -> int:
        return len(self._actors)
