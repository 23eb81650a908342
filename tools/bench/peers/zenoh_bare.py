"""Bare Zenoh (eclipse-zenoh, the version the project pins): a publisher and subscribers on one
key, default QoS, peer mode. A router (the project's, opened as `carlaverse router` opens it)
is there for discovery only, as multicast scouting is off: the peers then connect to each
other and the data goes direct.
"""

from __future__ import annotations

import json
import os
from collections import deque
from typing import Any

from carlaverse.messages import MessageError, Pose, decode_pose, encode_pose
from peers.transport import ChildProcess, Deliver, NoPoll, Plan, Transport

KEY = "bench/pose"
ONE_RX_THREAD = "(rx: (worker_threads: 1))"  # a `ZENOH_RUNTIME` value


def use_runtime(runtime: str) -> None:
    """Set Zenoh's thread pools for this process ("": Zenoh's defaults, two receive threads).
    Zenoh reads `ZENOH_RUNTIME` when the process first opens a session, not at import."""
    if runtime:
        os.environ["ZENOH_RUNTIME"] = runtime


def router_endpoint(plan: Plan) -> str:
    return f"tcp/127.0.0.1:{plan.ports[plan.receivers]}"


def lease_option(plan: Plan) -> dict[str, int]:
    """`FabricSettings` keywords for the run's `--lease-ms` (none: the fabric's own lease)."""
    lease_ms = int(plan.options.get("lease_ms") or 0)
    return {"lease_ms": lease_ms} if lease_ms > 0 else {}


def run_router(ready: Any, stop: Any, endpoint: str, lowlatency: bool, runtime: str = "",
               lease: dict[str, int] | None = None) -> None:  # fmt: skip
    """The project's router on loopback (as `carlaverse router` opens it) until `stop`."""
    from carlaverse.transport.session import FabricSettings, open_session

    use_runtime(runtime)
    settings = FabricSettings(mode="router", listen=[endpoint], lowlatency=lowlatency,
                              **(lease or {}))  # fmt: skip
    session = open_session(settings)
    ready.set()
    stop.wait()
    session.close()


def zenoh_router(plan: Plan, lowlatency: bool = False, runtime: str = "") -> ChildProcess:
    return ChildProcess("zenoh router", run_router, router_endpoint(plan), lowlatency, runtime,
                        lease_option(plan))  # fmt: skip


def _open_peer(plan: Plan, lowlatency: bool = False, runtime: str = "") -> Any:
    import zenoh

    from carlaverse.transport.session import LOWLATENCY_AUTOCONNECT

    entries: dict[str, Any] = {
        "mode": "peer",
        "connect/endpoints": [router_endpoint(plan)],
        "listen/endpoints": ["tcp/127.0.0.1:0"],
        "scouting/multicast/enabled": False,
    }
    if lowlatency:  # Zenoh's low-latency transport, as the fabric's `lowlatency` sets it
        entries["transport/unicast/lowlatency"] = True
        entries["transport/unicast/qos/enabled"] = False
        entries["scouting/gossip/autoconnect_strategy"] = LOWLATENCY_AUTOCONNECT
    config = zenoh.Config()
    for path, value in entries.items():
        config.insert_json5(path, json.dumps(value))
    use_runtime(runtime)
    return zenoh.open(config)


class ZenohSender:
    def __init__(
        self, plan: Plan, options: dict[str, Any], lowlatency: bool = False, runtime: str = ""
    ) -> None:
        self._session = _open_peer(plan, lowlatency, runtime)
        self._publisher = self._session.declare_publisher(KEY, **options)

    def send(self, pose: Pose) -> None:
        self._publisher.put(encode_pose(pose))

    def close(self) -> None:
        self._publisher.undeclare()
        self._session.close()


class ZenohReceiver(NoPoll):
    def __init__(
        self, plan: Plan, deliver: Deliver, indirect: bool, lowlatency: bool, runtime: str = ""
    ) -> None:
        import zenoh

        self._session = _open_peer(plan, lowlatency, runtime)

        def on_sample(sample: zenoh.Sample) -> None:
            deliver.payload(sample.payload.to_bytes())

        handler = zenoh.handlers.Callback(on_sample, indirect=indirect)
        self._subscriber = self._session.declare_subscriber(KEY, handler)

    def close(self) -> None:
        self._subscriber.undeclare()
        self._session.close()


class LoopedZenohReceiver(ZenohReceiver):
    """A bare Zenoh receiver in a node: its callback keeps each sample's bytes, and the main
    thread's loop (`poll`, at the pose path's node-loop rate) takes them, decodes each with the
    project's decoder and keeps every sender's newest pose: the least any application with a
    loop of its own does with what arrived (the pose path's `update()` does this and more)."""

    poll_period_s = 0.02  # [s] the pose path's node loop (`PoseReceiver.poll_period_s`)

    def __init__(self, plan: Plan, deliver: Deliver, lowlatency: bool, runtime: str = "") -> None:
        import zenoh

        self._session = _open_peer(plan, lowlatency, runtime)
        self._inbox: deque[tuple[str, bytes]] = deque()
        self.newest: dict[str, Pose] = {}
        keep = self._inbox.append

        def on_sample(sample: zenoh.Sample) -> None:
            payload = sample.payload.to_bytes()
            deliver.payload(payload)  # the harness's decode and arrival stamp
            keep((str(sample.key_expr), payload))

        self._subscriber = self._session.declare_subscriber(KEY, on_sample)

    def poll(self) -> None:
        inbox, newest = self._inbox, self.newest
        while inbox:
            key, payload = inbox.popleft()
            try:
                newest[key] = decode_pose(payload)
            except MessageError:
                continue

    def report(self) -> dict[str, Any]:
        """What the loop kept: each sender's newest pose (the bench's one publisher)."""
        return {"loop_senders": len(self.newest)}


class BareZenoh(Transport):
    label = "bare Zenoh"
    modules = ("zenoh",)
    # zenoh-python runs a callback on a Python thread of its own by default (`indirect`): the
    # network thread hands each sample over. `False` runs it on the network thread itself.
    indirect = True
    lowlatency = False  # Zenoh's low-latency transport in every process of the run
    runtime = ""  # Zenoh's thread pools in every process of the run ("": its defaults)

    def infrastructure(self, plan: Plan) -> list[ChildProcess]:
        return [zenoh_router(plan, self.lowlatency, self.runtime)]

    def publisher_options(self) -> dict[str, Any]:
        """`declare_publisher` options: Zenoh's defaults."""
        return {}

    def open_sender(self, plan: Plan) -> ZenohSender:
        return ZenohSender(plan, self.publisher_options(), self.lowlatency, self.runtime)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> ZenohReceiver:
        return ZenohReceiver(plan, deliver, self.indirect, self.lowlatency, self.runtime)


class BareZenohNodeLoop(BareZenoh):
    """Bare Zenoh in receivers that run a node loop as the pose path's do (50 Hz on the main
    thread, taking what the callback kept): the like-for-like reference for the pose path's
    receiver CPU, whose node loop costs a thread wake-up per period whatever it applies."""

    label = "bare Zenoh, node loop"

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> LoopedZenohReceiver:
        return LoopedZenohReceiver(plan, deliver, self.lowlatency, self.runtime)


class BareZenohDirect(BareZenoh):
    """Bare Zenoh with the callback on Zenoh's network thread (`Callback(indirect=False)`)."""

    label = "bare Zenoh, direct callback"
    indirect = False


class BareZenohLowLatency(BareZenoh):
    """Bare Zenoh in the pose path's low-latency set-up: the low-latency transport in every
    process and the callback on the network thread (the floor under 'pose path, lowlatency')."""

    label = "bare Zenoh, lowlatency, direct callback"
    indirect = False
    lowlatency = True


class BareZenohFastest(BareZenohLowLatency):
    """The fastest Zenoh set-up found for this workload, with none of the project's code: the
    low-latency transport, the callback on the network thread, and one receive thread
    (`ZENOH_RUNTIME`) in every process instead of Zenoh's two (fewer threads to wake per
    sample; a lower p50 on the 2-core machine of docs/benchmarks.md). No pose path built on
    Zenoh can be faster than this: it is the floor under any of them. A measurement row
    only, not in the smoke test: once in some thirty runs here a receiver's session of this
    set-up did not open within the harness's minute (reported as a failed run and left
    out), a cause not yet found."""

    label = "bare Zenoh, fastest set-up"
    runtime = ONE_RX_THREAD


class BareZenohPoseOptions(BareZenoh):
    """Bare Zenoh with the pose publisher's options (`NodeClient`): drop under congestion,
    real-time priority, remote destinations only."""

    label = "bare Zenoh, pose publisher options"

    def publisher_options(self) -> dict[str, Any]:
        import zenoh

        return {
            "congestion_control": zenoh.CongestionControl.DROP,
            "priority": zenoh.Priority.REAL_TIME,
            "allowed_destination": zenoh.Locality.REMOTE,
        }


class BareZenohExpress(BareZenoh):
    """Bare Zenoh whose publisher puts `express`: each sample leaves at once instead of
    waiting in Zenoh's batch for others to share a frame."""

    label = "bare Zenoh, express"

    def publisher_options(self) -> dict[str, Any]:
        return {"express": True}
