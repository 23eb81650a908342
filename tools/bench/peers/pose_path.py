"""This project's pose path: `NodeClient.publish_pose` in the publisher, and in each receiver a
`NodeClient` whose Zenoh callback parses the key and hands the pose's bytes to the world view
(`transport.inbound`), which the receiver's main loop checks, decodes and applies every 20 ms
(`client.update()`), as a node's loop does.

The arrival is stamped where the fabric hands the pose to the world view, after the key parse,
once the harness has decoded the bytes as it does for every transport (the same point
`tools/bench/bench_fabric.py` uses); the world view's own decode, in the update, is in the
receiver's CPU time, not in the delay. Admission
needs an authority: it runs in its own process (`EmptyDomain`, 50 Hz ticks) and, like every
node, receives each pose: it is this path's extra receiver. Its clock is CLOCK_MONOTONIC, so
session time is the host's monotonic time and a pose stamped with it is plausible to the
world view (which rejects poses far from session time).
"""

from __future__ import annotations

import time
from typing import Any

from carlaverse.messages import Pose
from peers.transport import ChildProcess, Deliver, Plan, Transport
from peers.zenoh_bare import lease_option, router_endpoint, zenoh_router

SESSION = "bench"
SENDER_ID = "tx"
JOIN_TIMEOUT_S = 30.0  # [s] a loaded 2-core host can take seconds to start five processes


def _fabric(plan: Plan, lowlatency: bool) -> Any:
    from carlaverse.transport.session import FabricSettings

    lease = lease_option(plan)
    return FabricSettings(mode="peer", connect=[router_endpoint(plan)], lowlatency=lowlatency,
                          **lease)  # fmt: skip


def _open_client(
    plan: Plan, lowlatency: bool, node_id: str, kind: str, actor_kind: str, keep_routes: bool = True
) -> Any:
    from carlaverse.transport.clock import MonotonicClock
    from carlaverse.transport.node_client import NodeClient, NodeSettings
    from carlaverse.transport.session import open_session

    session = open_session(_fabric(plan, lowlatency))
    # The project's low-latency set-up is both settings: the low-latency transport and the
    # pose callbacks on Zenoh's network thread.
    settings = NodeSettings(
        node_id=node_id, session=SESSION, kind=kind, actor_kind=actor_kind,
        pose_rate_hz=plan.rate_hz, direct_pose_callbacks=lowlatency,
    )  # fmt: skip
    client = NodeClient(session, settings, MonotonicClock())
    if not keep_routes:  # the diagnostic: no pose key declared, Zenoh matches every sample
        client.inbound.routes.limit = 0
    client.start()
    if not client.wait_joined(JOIN_TIMEOUT_S):
        raise TimeoutError(f"{node_id} was not admitted within {JOIN_TIMEOUT_S:g} s")
    return client


def run_authority(ready: Any, stop: Any, plan: Plan, lowlatency: bool) -> None:
    """The session's authority until `stop` is set (an infrastructure process)."""
    import threading

    from carlaverse.authority.domain import EmptyDomain
    from carlaverse.authority.service import Authority, AuthoritySettings
    from carlaverse.transport.clock import MonotonicClock
    from carlaverse.transport.session import open_session

    session = open_session(_fabric(plan, lowlatency))
    settings = AuthoritySettings(session=SESSION)
    authority = Authority(session, settings, MonotonicClock(), EmptyDomain()).start()
    ticking = threading.Thread(target=authority.run, name="authority-tick", daemon=True)
    ticking.start()
    ready.set()
    stop.wait()
    authority.stop()
    ticking.join(timeout=5)
    authority.close()
    session.close()


class PoseSender:
    def __init__(self, plan: Plan, lowlatency: bool) -> None:
        self._client = _open_client(plan, lowlatency, SENDER_ID, "scripted", "car")

    def send(self, pose: Pose) -> None:
        self._client.publish_pose(pose)

    def close(self) -> None:
        self._client.close()
        self._client.session.close()


class PoseReceiver:
    poll_period_s = 0.02  # [s] the node loop applying what arrived (50 Hz)

    def __init__(
        self, plan: Plan, lowlatency: bool, index: int, deliver: Deliver, keep_routes: bool = True
    ) -> None:
        self.in_callback_s: list[float] = []
        self._entered = 0.0
        if plan.options.get("time_callback"):  # harness work in this receiver's CPU: asked for
            self._stamp_callback_entry()
        self._client = _open_client(  # an observer: no actor
            plan, lowlatency, f"rx{index}", "observer", "", keep_routes
        )
        world = self._client.world
        push_wire = world.intake.pose

        def stamped(node_id: str, payload: bytes, rx_t: float) -> None:
            # The fabric's part ends where the harness takes over (and stamps the arrival).
            # The fabric hands the bytes on as they came; the harness decodes them with the
            # project's decoder, as it does for every other transport.
            if self._entered:
                self.in_callback_s.append(time.monotonic() - self._entered)
            deliver.payload(payload)
            push_wire(node_id, payload, rx_t)

        world.intake.pose = stamped  # type: ignore[method-assign]

    def _stamp_callback_entry(self) -> None:
        """Note when the fabric's pose callback starts (`Inbound._on_pose`, wrapped in this
        receiver's process before its subscribers exist), so the time from there to the
        hand-over is what the project's callback costs (clock, key parse)."""
        from carlaverse.transport.inbound import Inbound

        on_pose = Inbound._on_pose

        def entered(inbound: Inbound, sample: Any) -> None:
            self._entered = time.monotonic()
            on_pose(inbound, sample)

        Inbound._on_pose = entered  # type: ignore[method-assign]

    def poll(self) -> None:
        self._client.update()

    def report(self) -> dict[str, Any]:
        """What the world view made of the poses (accepted ones count warm-ups too)."""
        world = self._client.world
        stats = world.stats.get(SENDER_ID)
        return {
            "world_view_accepted": 0 if stats is None else stats.count,
            "world_view_rejected": dict(world.rejected),
            "in_callback_s": self.in_callback_s,
        }

    def close(self) -> None:
        self._client.close()
        self._client.session.close()


class PosePath(Transport):
    label = "pose path (this project)"
    modules = ("zenoh",)
    extra_receiver = False  # the authority receives every pose
    lowlatency = False  # the fabric's `lowlatency` setting, in every process of the run
    node_loop = True  # whether each receiver's main thread applies what arrived (`update()`)
    keep_routes = True  # whether each receiver declares the pose keys it hears (`key_routes`)

    def infrastructure(self, plan: Plan) -> list[Any]:
        router = zenoh_router(plan, self.lowlatency)
        authority = ChildProcess("authority", run_authority, plan, self.lowlatency)
        return [router, authority]

    def open_sender(self, plan: Plan) -> PoseSender:
        return PoseSender(plan, self.lowlatency)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> PoseReceiver:
        receiver = PoseReceiver(plan, self.lowlatency, index, deliver, self.keep_routes)
        if not self.node_loop:
            receiver.poll_period_s = None  # type: ignore[misc]
        return receiver


class PosePathLowLatency(PosePath):
    """The same path with `fabric: {lowlatency: true}` (Zenoh's low-latency transport, no QoS
    priorities): the project's own low-latency configuration, as DDS runs in its own."""

    label = "pose path, lowlatency"
    lowlatency = True


class PosePathNoNodeLoop(PosePath):
    """Diagnostic: the pose path whose receivers never run their node loop, so the Zenoh
    callback has the process to itself (the world view's inbox just fills)."""

    label = "pose path, no node loop"
    node_loop = False


class PosePathNoRoutes(PosePath):
    """Diagnostic: the pose path whose receivers declare no pose key (`transport.key_routes`),
    so Zenoh matches each sample's key against its whole routing table, as before."""

    label = "pose path, pose keys not declared"
    keep_routes = False
