"""The receive benchmark's child processes: the publisher and one subscriber per layer.

`bench_receive.py` starts each with a pipe (its last argument) and drives it by commands; kept
apart from the orchestration and the report, which a spawned child need not import.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any, NamedTuple

from benchdoc import own_cpu_s

from carlaverse.support.stats import percentile

SESSION = "recv"
NODE_ID = "listener"
IDLE = "idle"  # the window with the publisher paused
EXPRESS = "+express"  # a layer's name ends so when the publisher puts express
DIGEST = "+digest"  # ... and so when the poses come many to a sample, as the authority relays
RING_CAPACITY = 4096  # samples; a ring nobody drains keeps only the newest
UPDATE_PERIOD_S = 0.01  # [s] a node's loop at 100 Hz
ORPHAN_S = 300.0  # [s] of silence after which a child decides its orchestrator is gone
SLICES = 10  # a period's sends are spread over this many slices
LAG_LIMIT_S = 0.1  # [s] a publisher this far behind its deadlines starts afresh, no burst
BASE_SPEED = 8.0  # [m/s] the slowest ego
LANE_M = 3.5  # [m] between the egos' parallel lanes


def _commands(conn: Connection) -> Iterator[Any]:
    """The orchestrator's commands until `quit`; ends as well when it is gone or has been
    silent for ORPHAN_S (a child must not outlive a run that crashed)."""
    while conn.poll(ORPHAN_S):
        try:
            command = conn.recv()
        except EOFError:
            return
        if command == "quit":
            return
        yield command


class Flock:
    """`egos` egos driving east on parallel lanes, each publishing its pose at `rate_hz`; or
    (`digesting`) the same poses put as the authority's relay puts them: a slice's poses in
    one `PoseDigest` on `world/@egos`, stamped by this session (the subscribers trust it as
    their authority). A slice lasts 2 ms at 50 Hz, the relay's shipped period, so a digest
    holds what the relay's would: a tenth of the egos, ~26 poses at 256."""

    def __init__(self, session: Any, egos: int, rate_hz: float) -> None:
        import zenoh

        from carlaverse.keys import Keys
        from carlaverse.transport.interest import POSE_QOS

        keys = Keys(SESSION)

        def publishers(**extra: object) -> list[Any]:
            qos = {**POSE_QOS, **extra}  # as a node puts its pose, and `extra` on top
            return [session.declare_publisher(keys.pose(f"e{i}", "t0_0"), **qos)
                    for i in range(egos)]  # fmt: skip

        self.batched = publishers()
        self.express = publishers(express=True)  # one frame per pose, never batched
        self.publishers = self.batched  # the set `_send` puts with
        self.digest = session.declare_publisher(
            keys.pose_digest, congestion_control=zenoh.CongestionControl.DROP
        )  # as the relay declares it
        self.new_timestamp = session.new_timestamp
        self.digesting = False
        self.ids = [f"e{i}" for i in range(egos)]
        self.speeds = [BASE_SPEED + i % 8 for i in range(egos)]  # [m/s]
        self.period_s = 1.0 / rate_hz
        self.sending = threading.Event()
        self.stop = threading.Event()
        self.sent = 0  # poses put so far; read by the command loop
        self.seq = 0
        self.t0 = time.time()

    def run(self) -> None:
        while not self.stop.is_set():
            if self.sending.wait(0.1):
                self._paced()

    def _paced(self) -> None:
        """Send on a deadline (next += slice) until paused or stopped: each period in SLICES
        slices, a slice's share of the egos at a time. Egos on their own machines are not in
        step; all of them in one burst would queue at the receiver and show as delay."""
        deadline, part = time.monotonic(), 0
        while self.sending.is_set() and not self.stop.is_set():
            self._send(part)
            part = (part + 1) % SLICES
            deadline += self.period_s / SLICES
            delay = deadline - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -LAG_LIMIT_S:  # catching up in a burst would not be the stream we mean
                deadline = time.monotonic()

    def _send(self, part: int) -> None:
        from carlaverse import messages as m
        from carlaverse.messages import Pose, encode_pose

        # Wall time is session time here: a subscriber's SessionClock(MonotonicClock()) before
        # any clock exchange assumes the hosts' wall clocks agree (its offset is time.time() −
        # time.monotonic()), and on one host they do. So the world view's plausibility check
        # passes and its interpolation sees true latencies. Each pose is stamped as it is put:
        # one stamp for the whole burst would count the burst's length (ms) as delay.
        if part == 0:  # a new period: every ego's next pose
            self.seq += 1
        rows = []
        for i in range(part, len(self.publishers), SLICES):
            t, vx = time.time(), self.speeds[i]
            pose = Pose(self.seq, t, vx * (t - self.t0), LANE_M * i, vx=vx)
            if self.digesting:
                rows.append(encode_pose(pose))
            else:
                self.publishers[i].put(encode_pose(pose))
            self.sent += 1
        if rows:
            digest = m.PoseDigest(self.seq * SLICES + part, self.ids[part::SLICES], b"".join(rows))
            self.digest.put(m.POSE_DIGEST.encode(digest), timestamp=self.new_timestamp())


def publisher_main(endpoint: str, egos: int, rate_hz: float, conn: Connection) -> None:
    """The publisher (a child). First it sends its session's id (the digest layers trust it
    as their authority). Commands: `publish` (as nodes put), `publish-express` (each pose in a
    frame of its own), `publish-digest` (many to a sample, as the authority relays) and
    `pause` switch sending; `mark` asks for the poses sent so far. Each is answered with
    (poses sent, monotonic time), so the orchestrator also learns that the publisher is
    alive."""
    from carlaverse.transport.session import FabricSettings, open_session

    session = open_session(FabricSettings(connect=[endpoint]))
    flock = Flock(session, egos, rate_hz)
    sender = threading.Thread(target=flock.run, name="flock", daemon=True)
    sender.start()
    conn.send(str(session.zid()))  # what a timestamp of this session names
    for command in _commands(conn):
        if command in ("publish", "publish-express", "publish-digest"):
            flock.publishers = flock.express if command == "publish-express" else flock.batched
            flock.digesting = command == "publish-digest"
            flock.sending.set()
        elif command == "pause":
            flock.sending.clear()
        conn.send((flock.sent, time.monotonic()))
    flock.stop.set()
    sender.join(5)
    session.close()


class Reading(NamedTuple):
    cpu_s: float  # [s] this process, all threads
    received: int
    update_cpu_s: float  # [s] the update thread's own
    t: float  # [s] monotonic


@dataclass
class Receiver:
    """One layer's subscription in a subscriber child, and what it counted. The counters are
    bumped on Zenoh's callback thread and read on the main one (ints under the GIL)."""

    counts: bool = True  # False: the layer cannot see its samples (the ring)
    received: int = 0
    update_cpu_s: float = 0.0  # [s]
    entities: list[Any] = field(default_factory=list)
    stop: threading.Event = field(default_factory=threading.Event)
    threads: list[threading.Thread] = field(default_factory=list)
    world: Any = None
    # [s] arrival minus send time of each pose in the window (project layers only): what the
    # session mode costs in delay, beside what it costs in CPU
    latency_s: list[float] = field(default_factory=list)

    def reading(self) -> Reading:
        return Reading(own_cpu_s(), self.received, self.update_cpu_s, time.monotonic())

    def since(self, start: Reading) -> dict[str, Any]:
        now = self.reading()
        report = {
            "seconds": now.t - start.t,
            "cpu_s": now.cpu_s - start.cpu_s,
            "received": now.received - start.received if self.counts else None,
            "update_cpu_s": now.update_cpu_s - start.update_cpu_s,
        }
        if self.latency_s:
            report["latency_ms"] = [percentile(self.latency_s, q) * 1e3 for q in (0.5, 0.99)]
        if self.world is not None:  # evidence that the world view accepted what it was given
            report["egos_seen"] = len(self.world.egos)
            report["rejected"] = dict(self.world.rejected)
        return report

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(5)
        for entity in self.entities:
            entity.undeclare()


class Feed(NamedTuple):
    """What a layer subscribes to: every ego's pose key, or (`authority` set) the pose digest
    that session puts."""

    authority: str = ""  # the digest publisher's session id; "" for a sample per pose

    @property
    def key(self) -> str:
        from carlaverse.keys import Keys

        keys = Keys(SESSION)
        return keys.pose_digest if self.authority else keys.all_ego("pose")


def _ring(session: Any, egos: int, feed: Feed) -> Receiver:
    import zenoh

    receiver = Receiver(counts=False)
    ring = zenoh.handlers.RingChannel(RING_CAPACITY)
    receiver.entities.append(session.declare_subscriber(feed.key, ring))
    return receiver


def _handoff(session: Any, egos: int, feed: Feed) -> Receiver:
    """Like the scale bench's floor subscriber (scale_children.floor_main). A digest's poses
    cannot be counted without decoding it, which is the project's work: sent stands in."""
    import zenoh

    receiver = Receiver(counts=not feed.authority)

    def on_sample(sample: zenoh.Sample) -> None:
        sample.payload.to_bytes()
        receiver.received += 1

    callback = zenoh.handlers.Callback(on_sample)
    receiver.entities.append(session.declare_subscriber(feed.key, callback))
    return receiver


def _inbound(session: Any, egos: int, feed: Feed) -> Receiver:
    return _project(session, egos, feed, updating=False)


def _node(session: Any, egos: int, feed: Feed) -> Receiver:
    return _project(session, egos, feed, updating=True)


def _project(session: Any, egos: int, feed: Feed, updating: bool) -> Receiver:
    """The project's pose path as a `NodeClient` declares it, without the rest of a node."""
    from carlaverse.messages import pose_stamp, pose_stamps
    from carlaverse.transport.clock import MonotonicClock, SessionClock
    from carlaverse.transport.inbound import Inbound
    from carlaverse.world.remote_actor import InterpolationSettings
    from carlaverse.world.world_view import WorldView

    world = WorldView(NODE_ID, InterpolationSettings())
    for i in range(egos):  # as if their tokens had come
        world.intake.present(f"e{i}")
    world.update(0.0)
    clock = SessionClock(MonotonicClock())
    inbound = Inbound(NODE_ID, world.intake, clock, lost=lambda: None, appeared=lambda: None)
    receiver = Receiver(world=world)
    push_wire = world.intake.pose

    latency = receiver.latency_s
    at = clock.at  # the fabric stamps arrivals on the local clock (`transport.inbound`)

    def counted(node_id: str, payload: bytes, rx_t: float) -> None:  # one call more per pose
        receiver.received += 1
        latency.append(at(rx_t) - pose_stamp(payload)[1])
        push_wire(node_id, payload, rx_t)

    push_digest = world.intake.pose_rows

    def counted_many(ids: list[str], rows: bytes, rx_t: float) -> None:  # one call per digest
        receiver.received += len(ids)
        latency.extend((at(rx_t) - pose_stamps(rows)[1]).tolist())
        push_digest(ids, rows, rx_t)

    world.intake.pose = counted  # type: ignore[method-assign]
    world.intake.pose_rows = counted_many  # type: ignore[method-assign]
    if feed.authority:
        inbound.authority_id = feed.authority  # as a join reply names it
        handler = inbound.digest_handler()
    else:
        handler = inbound.pose_handler()
    receiver.entities.append(session.declare_subscriber(feed.key, handler))
    if updating:
        loop = threading.Thread(target=_update_loop, args=(world, clock, receiver), daemon=True)
        receiver.threads.append(loop)
        loop.start()
    return receiver


def _update_loop(world: Any, clock: Any, receiver: Receiver) -> None:
    """A node's loop at 100 Hz, doing only its world view's part; times its own CPU."""
    deadline = time.monotonic()
    while not receiver.stop.is_set():
        began = time.thread_time()
        world.update(clock.now())
        receiver.update_cpu_s += time.thread_time() - began
        deadline += UPDATE_PERIOD_S
        receiver.stop.wait(max(0.0, deadline - time.monotonic()))


SETUPS: dict[str, Callable[[Any, int, Feed], Receiver]] = {
    IDLE: _handoff,  # the idle window's session is subscribed, as the layers' are
    "zenoh": _ring,
    "handoff": _handoff,
    "inbound": _inbound,
    "node": _node,
}


def subscriber_main(
    endpoint: str, mode: str, layer: str, egos: int, publisher: str, conn: Connection
) -> None:
    """A subscriber (a child) of one layer; `publisher` is the publisher's session id, which a
    digest layer trusts as its authority. Commands: `start` opens the measured window, `stop`
    closes it and answers the window's report."""
    from carlaverse.transport.session import FabricSettings, open_session

    session = open_session(FabricSettings(mode=mode, connect=[endpoint]))  # type: ignore[arg-type]
    feed = Feed(publisher if layer.endswith(DIGEST) else "")
    receiver = SETUPS[layer.removesuffix(EXPRESS).removesuffix(DIGEST)](session, egos, feed)
    conn.send("joined")
    start = receiver.reading()
    for command in _commands(conn):
        if command == "start":
            start = receiver.reading()
            receiver.latency_s.clear()
            conn.send("started")
        elif command == "stop":
            conn.send({**receiver.since(start), **_links(session)})
    receiver.close()
    session.close()


def _links(session: Any) -> dict[str, int]:
    """The session's links: a peer learns the publisher from the router (gossip) and may take
    its poses over a direct link, which a client never does."""
    info = session.info
    return {"routers": len(list(info.routers_zid())), "peers": len(list(info.peers_zid()))}
