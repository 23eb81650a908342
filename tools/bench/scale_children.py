"""The scale benchmark's child processes: the authority, the probes and the floor.

`bench_scale.py` starts each with a pipe (its last argument) and drives it by commands:
`start` opens a measured window, `stop` closes it and the child sends its report (a dict),
`quit` ends it. Kept apart from the orchestration, which a spawned child need not import.
"""

from __future__ import annotations

import gc
import os
import threading
import time
from typing import Any

from benchdoc import own_cpu_s

from carlaverse.support.stats import percentile

SESSION = "scale"


class GcPauses:
    """The cyclic collector's pauses in this process [ms], from `gc.callbacks`."""

    def __init__(self) -> None:
        self.ms: list[float] = []
        self._began = 0.0
        gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            self._began = time.perf_counter()
        else:
            self.ms.append((time.perf_counter() - self._began) * 1e3)


# ---------------------------------------------------------------- the authority (a child)


def authority_main(endpoint: str, scenario: str, priority: int, conn: Any) -> None:
    """The authority on `scenario`; reports its ticks and stalls per window."""
    from carlaverse.authority.service import Authority, AuthoritySettings
    from carlaverse.authority.traffic_domain import load_domain
    from carlaverse.transport.clock import WallAlignedClock
    from carlaverse.transport.session import FabricSettings, open_session

    domain = load_domain(scenario)
    session = open_session(FabricSettings(connect=[endpoint]))
    settings = AuthoritySettings(session=SESSION, tick_priority=priority)
    authority = Authority(session, settings, WallAlignedClock(), domain).start()
    pauses = GcPauses()
    ticking = threading.Thread(target=authority.run, daemon=True)
    ticking.start()
    conn.send((os.getpid(), getattr(domain.engine, "pid", None)))  # SUMO's own process, if any
    relay = authority.digest
    while (command := conn.recv()) != "quit":
        if isinstance(command, tuple) and command[0] == "digest_ms" and relay is not None:
            relay.period_s = command[1] / 1e3  # read by the relay before its next wait
            conn.send("ok")
        elif command == "start":
            authority.tick_ms.clear()
            authority.overruns = 0
            pauses.ms.clear()
            if relay is not None:
                relay.digests = relay.poses = 0
        elif command == "stop":
            ticks = list(authority.tick_ms)
            conn.send({
                "ticks": len(ticks), "p50": percentile(ticks, 0.5), "p99": percentile(ticks, 0.99),
                "max": max(ticks, default=float("nan")), "overruns": authority.overruns,
                "npcs": npcs(domain), "egos": len(authority.roster.tracks),
                "gc_n": len(pauses.ms), "gc_max_ms": max(pauses.ms, default=0.0),
                "late": getattr(domain.engine, "late_steps", 0),
                "digests": relay.digests if relay else 0, "relayed": relay.poses if relay else 0,
            })  # fmt: skip
    authority.stop()
    ticking.join(5)  # the tick thread must be done with SUMO before close() ends it
    authority.close()
    session.close()


def npcs(domain: Any) -> int:
    """NPCs in the batch the tick last published. Not read from the engine: it belongs to the
    tick thread (`SumoProcess`), and this runs on another."""
    batch = domain.snapshot_parts()[0]
    return 0 if batch is None else len(batch.ids)


# ---------------------------------------------------------------- a real node (a child)


class Receipts:
    """What a probe heard in a window; `heard` runs in Zenoh's callback thread."""

    def __init__(self) -> None:
        self.recording = False
        self.latency_s: list[float] = []
        self.seqs: dict[str, list[int]] = {}  # sender -> [first, last, count]
        # On the digest, each pose's delay in two parts at the authority's timestamp of the
        # digest that carried it: reaching the authority and waiting for the relay, then the
        # digest's hop to this node (the same clocks: the session's is the authority's).
        self.stamp_s = float("nan")  # the digest being applied: when the authority put it
        self.to_relay_s: list[float] = []
        self.hop_s: list[float] = []

    def heard(self, node_id: str, seq: int, latency_s: float) -> None:
        if not self.recording:
            return
        self.latency_s.append(latency_s)
        span = self.seqs.get(node_id)
        if span is None:
            self.seqs[node_id] = [seq, seq, 1]
        else:
            span[1] = max(span[1], seq)
            span[2] += 1


def probe_main(
    endpoint: str,
    node_id: str,
    radius_m: float,
    x: float,
    y: float,
    conn: Any,
    digest: bool = False,
) -> None:
    """A node standing at (x, y) with interest radius `radius_m` (0: hears everything);
    `digest`: it hears the poses through the authority's pose digest."""
    from carlaverse.messages import Pose, pose_stamp, pose_stamps
    from carlaverse.transport.clock import MonotonicClock
    from carlaverse.transport.node_client import NodeClient, NodeSettings
    from carlaverse.transport.session import FabricSettings, open_session

    session = open_session(FabricSettings(connect=[endpoint]))
    settings = NodeSettings(
        node_id=node_id, session=SESSION, interest_radius_m=radius_m, pose_digest=digest
    )
    client = NodeClient(session, settings, MonotonicClock())
    receipts = Receipts()
    push_wire = client.world.intake.pose
    at = client.clock.at  # the fabric stamps arrivals on the local clock (`transport.inbound`)

    def stamped(sender: str, payload: bytes, rx_t: float) -> None:
        seq, t = pose_stamp(payload)
        receipts.heard(sender, seq, at(rx_t) - t)
        push_wire(sender, payload, rx_t)

    push_digest = client.world.intake.pose_rows

    def stamped_many(ids: list[str], rows: bytes, local_t: float) -> None:
        seqs, times = pose_stamps(rows)
        sent = times.tolist()
        rx_t = at(local_t)
        for sender, seq, t in zip(ids, seqs.tolist(), sent, strict=True):
            receipts.heard(sender, seq, rx_t - t)
        if receipts.recording:
            stamp = receipts.stamp_s
            receipts.to_relay_s += [stamp - t for t in sent]
            receipts.hop_s += [rx_t - stamp] * len(ids)
        push_digest(ids, rows, local_t)

    if digest:  # the digest's timestamp, noted before the node's own handler applies it
        from carlaverse.transport.inbound import Inbound

        on_digest = Inbound._on_digest

        def noted(self: Inbound, sample: Any) -> None:
            stamp = sample.timestamp
            receipts.stamp_s = stamp.get_time().timestamp() if stamp else float("nan")
            on_digest(self, sample)

        Inbound._on_digest = noted  # type: ignore[method-assign]  # this child's class only

    client.world.intake.pose = stamped  # type: ignore[method-assign]
    client.world.intake.pose_rows = stamped_many  # type: ignore[method-assign]
    client.start(lambda t: Pose(0, t, x, y))
    client.wait_joined(60)
    conn.send("joined")
    started_cpu = started_t = 0.0
    while True:
        if conn.poll(0.01):
            command = conn.recv()
            if command == "quit":
                break
            if command == "start":
                receipts.latency_s, receipts.seqs = [], {}
                receipts.to_relay_s, receipts.hop_s = [], []
                started_cpu, started_t = own_cpu_s(), time.monotonic()
                receipts.recording = True
            elif command == "stop":
                receipts.recording = False
                conn.send(_probe_report(receipts, started_cpu, started_t, client))
        client.update()  # drain the world's inbox as a node's loop would
    client.close()
    session.close()


def floor_main(endpoint: str, conn: Any, drain_ms: float = 0.0) -> None:
    """The floor under `probe-all`: a bare zenoh-python subscriber to every pose of the
    session, whose callback only takes the payload's bytes (no project code). Its CPU per pose
    is what any Python node pays to be handed a sample; the fabric's share is the rest.

    `drain_ms` > 0: no Python callback per sample; the samples wait in a Zenoh ring that a
    thread drains every `drain_ms`, as the authority's intake takes them, to tell what a
    sample costs from what a callback costs."""
    import zenoh

    from carlaverse.authority.pose_intake import RING_CAPACITY
    from carlaverse.keys import Keys
    from carlaverse.transport.session import FabricSettings, open_session

    session = open_session(FabricSettings(connect=[endpoint]))
    count = [0]
    stop = threading.Event()
    key = Keys(SESSION).all_ego("pose")
    if drain_ms > 0:
        subscriber = session.declare_subscriber(key, zenoh.handlers.RingChannel(RING_CAPACITY))

        def drain() -> None:
            while not stop.wait(drain_ms / 1e3):
                while (sample := subscriber.try_recv()) is not None:
                    sample.payload.to_bytes()
                    count[0] += 1

        drainer = threading.Thread(target=drain, name="floor-drain", daemon=True)
        drainer.start()
    else:

        def on_sample(sample: zenoh.Sample) -> None:
            sample.payload.to_bytes()
            count[0] += 1

        subscriber = session.declare_subscriber(key, zenoh.handlers.Callback(on_sample))
    conn.send("joined")
    started_cpu = started_t = 0.0
    while (command := conn.recv()) != "quit":
        if command == "start":
            count[0], started_cpu, started_t = 0, own_cpu_s(), time.monotonic()
        elif command == "stop":
            seconds = time.monotonic() - started_t
            conn.send({"seconds": seconds, "cpu_s": own_cpu_s() - started_cpu, "poses": count[0]})
    stop.set()
    if drain_ms > 0:  # done with the ring before it goes: undeclaring it under a reader fails
        drainer.join(5)
    subscriber.undeclare()
    session.close()


def _probe_report(receipts: Receipts, cpu0: float, t0: float, client: Any) -> dict[str, Any]:
    lat = receipts.latency_s
    spanned = sum(last - first + 1 for first, last, _ in receipts.seqs.values())
    return {
        "seconds": time.monotonic() - t0, "cpu_s": own_cpu_s() - cpu0, "poses": len(lat),
        "senders": len(receipts.seqs), "spanned": spanned,
        "p50_ms": percentile(lat, 0.5) * 1e3, "p99_ms": percentile(lat, 0.99) * 1e3,
        "max_ms": max(lat, default=float("nan")) * 1e3,
        "sync_ms": client.clock.uncertainty_s * 1e3, "tiles": len(client.interest.tiles)
        if client.interest else 0,
        **({"to_relay_p50_ms": percentile(receipts.to_relay_s, 0.5) * 1e3,
            "to_relay_p99_ms": percentile(receipts.to_relay_s, 0.99) * 1e3,
            "hop_p50_ms": percentile(receipts.hop_s, 0.5) * 1e3,
            "hop_p99_ms": percentile(receipts.hop_s, 0.99) * 1e3} if receipts.hop_s else {}),
    }  # fmt: skip
