"""An automated vehicle on ROS 2 as an ego of the session (`carlaverse ros2 av`).

The AV stack publishes `nav_msgs/Odometry` on a topic (pose in the map frame, twist in its
own frame, REP 105); this node joins the session as an ordinary ego -- its node id, actor kind
and extent in the join request, its liveliness token, its poses at the rate the odometry
comes -- and gives back, as ROS 2 topics:

    <prefix>/<id>/collisions   carlaverse_msgs/CollisionImpulse  each impulse the authority
                                                                 decides for this ego
    and the world as `bridge.Ros2View` shows it (its own actor left out).

The same rules hold as for any node: while odometry keeps coming, the ego is there; when it
stops for `odom_timeout_s`, no pose goes out, and the session despawns the ego after its
despawn timeout (reason `timeout`), as it would a silent driving simulator. Each pose is
valid at the session time its odometry arrived (the link's delay is the ego's delay; the
message's own stamp is on the AV's clock, which need not be the session's).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Annotated, Any

import msgspec
import zenoh

from carlaverse import messages as m
from carlaverse.config import StrictStruct
from carlaverse.ros2 import types as t
from carlaverse.ros2 import world_msgs as w
from carlaverse.ros2.bridge import Ros2Settings, Ros2View, next_due
from carlaverse.ros2.keys import check_topic, ros_token
from carlaverse.ros2.node import RosNode, RosPublisher
from carlaverse.support.tally import Tally
from carlaverse.transport.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.transport.session import FabricSettings

log = logging.getLogger(__name__)


class AvSettings(StrictStruct):
    """The `av:` section: where the AV's odometry comes from."""

    odom_topic: str = "/av/odom"
    # [s] odometry older than this is not sent on: the AV went quiet
    odom_timeout_s: Annotated[float, msgspec.Meta(gt=0, le=10)] = 0.5
    # publish the world (`bridge.Ros2View`) too; off when a `ros2 view` serves the same
    # domain, which would otherwise get /clock and /tf from both
    world: bool = True

    def __post_init__(self) -> None:
        check_topic(self.odom_topic, "odom_topic")


class AvConfig(StrictStruct):
    node: NodeSettings = NodeSettings(kind="ros2-av", actor_kind="car")
    fabric: FabricSettings = FabricSettings()
    ros2: Ros2Settings = Ros2Settings(node_name="carlaverse_av")
    av: AvSettings = AvSettings()

    def __post_init__(self) -> None:
        if self.node.actor_kind not in m.ACTOR_KINDS:
            known = ", ".join(m.ACTOR_KINDS)
            raise ValueError(f"node.actor_kind {self.node.actor_kind!r}: one of {known}")


def await_odometry(
    session: zenoh.Session, config: AvConfig, stop: threading.Event, timeout_s: float | None
) -> bool:
    """Block until the AV's first odometry that would make a pose is heard (True), or until
    `stop` or `timeout_s` (False): the AV joins once it drives, not before, so a stack that
    is not up yet is not despawned and re-joined every despawn timeout meanwhile."""
    s = config.ros2
    node = RosNode(session, s.node_name, domain=s.domain_id)
    probe = AvParticipantNode(config)
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    try:
        node.subscription(config.av.odom_topic, t.ODOMETRY, probe.on_odometry)
        while not probe.odometry_heard:
            if deadline is not None and time.monotonic() >= deadline:
                return False
            if stop.wait(0.02):
                return False
        return True
    finally:
        node.close()


class AvParticipantNode:
    name = "ros2-av"
    config_type = AvConfig

    def __init__(self, config: AvConfig, monotonic: Callable[[], float] = time.monotonic) -> None:
        """`monotonic`: the clock odometry's age is read on [s] (a test's manual clock)."""
        self.config = config
        self._monotonic = monotonic
        self.dropped = Tally()
        self.odometry_heard = 0
        self.impulses_sent = 0
        self.view: Ros2View | None = None
        self._node: RosNode | None = None
        self._collisions: RosPublisher | None = None
        # (pose without its time, monotonic arrival [s], serial): replaced whole by Zenoh's
        # thread, read by the pose thread -- one reference, so no lock.
        self._latest: tuple[m.Pose, float, int] | None = None
        self._sent_serial = 0
        self._next_t = 0.0

    @property
    def collisions_topic(self) -> str:
        return f"{self.config.ros2.prefix}/{ros_token(self.config.node.node_id)}/collisions"

    # ------------------------------------------------------------ Zenoh's thread

    def on_odometry(self, message: dict[str, Any]) -> None:
        """Check one odometry message and keep it as the newest pose (never waits)."""
        frame = message["header"]["frame_id"]
        if frame not in ("", self.config.ros2.map_frame):
            self.dropped.add("odom/frame")
            return
        try:
            pose = w.pose_from_odometry(message, 0.0)
        except ValueError:
            self.dropped.add("odom/value")
            return
        self.odometry_heard += 1
        self._latest = (pose, self._monotonic(), self.odometry_heard)

    # ------------------------------------------------------------ pose thread

    def pose_source(self) -> PoseSource | None:
        return self.pose_at

    def pose_at(self, now: float) -> m.Pose | None:
        """The newest odometry not sent yet, at the session time it arrived; None when
        there is none, or when it is older than the timeout (the AV went quiet)."""
        latest = self._latest
        if latest is None or latest[2] == self._sent_serial:
            return None
        pose, rx_mono, serial = latest
        age = self._monotonic() - rx_mono
        if age > self.config.av.odom_timeout_s:
            return None
        self._sent_serial = serial
        return msgspec.structs.replace(pose, t=now - age)

    # ------------------------------------------------------------ the node's loop

    def step(self, client: NodeClient, now: float) -> None:
        if self._node is None:  # the session exists from the first step on
            self._start(client)
        assert self._collisions is not None
        while client.impulses:
            impulse = client.impulses.popleft()
            self._collisions.publish(w.collision(impulse, self.config.ros2.map_frame),
                                     round(now * 1e9))  # fmt: skip
            self.impulses_sent += 1
        if self.view is not None and now >= self._next_t:
            self._next_t = next_due(self._next_t, now, 1.0 / self.config.ros2.rate_hz)
            self.view.publish(now)

    def _start(self, client: NodeClient) -> None:
        s = self.config.ros2
        self._node = node = RosNode(client.session, s.node_name, domain=s.domain_id)
        self._collisions = node.publisher(self.collisions_topic, t.COLLISION_IMPULSE)
        if self.config.av.world:
            self.view = Ros2View(client, node, s)
        node.subscription(self.config.av.odom_topic, t.ODOMETRY, self.on_odometry)

    def close(self) -> None:
        if self.view is not None:
            self.view.close()
        if self._node is not None:
            self._node.close()

    def report(self) -> dict[str, Any]:
        dropped = self.dropped.snapshot()
        if self._node is not None:
            dropped |= self._node.dropped.snapshot()
        world = self.view.report() if self.view is not None else {}
        return {"odometry_heard": self.odometry_heard, "impulses_sent": self.impulses_sent,
                "odometry_dropped": dropped, **world}  # fmt: skip
