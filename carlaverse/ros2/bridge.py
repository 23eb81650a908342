"""The session as ROS 2 topics: a node's world view published over rmw_zenoh.

`Ros2View` reads a joined node's world view (`NodeClient.world`: remote egos interpolated,
NPCs, lights) and publishes, at each `publish(now)`:

    /clock                          rosgraph_msgs/Clock             session time
    /tf                             tf2_msgs/TFMessage              map -> <actor>/base_link
    <prefix>/<ego>/odom             nav_msgs/Odometry               one topic per ego
    <prefix>/objects                vision_msgs/Detection3DArray    every actor, ground truth
    <prefix>/markers                visualization_msgs/MarkerArray  a box per actor, for RViz
    <prefix>/traffic_lights         carlaverse_msgs/TrafficLightArray  each lights message

`Ros2BridgeNode` is the node kind that runs it as an observer (`carlaverse ros2 view`); the
AV participant (`av_participant`) runs it beside its own ego.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from typing import Annotated, Any

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.ros2 import types as t
from carlaverse.ros2 import world_msgs as w
from carlaverse.ros2.ego_catalog import EgoCatalog
from carlaverse.ros2.keys import check_node_name, check_topic, ros_token
from carlaverse.ros2.node import RosNode, RosPublisher
from carlaverse.transport.node_client import NodeClient, NodeSettings, PoseSource
from carlaverse.transport.session import FabricSettings
from carlaverse.world.remote_actor import ActorView

log = logging.getLogger(__name__)

MARKER_PERIODS = 3.0  # a marker lives this many publishing periods: a gone actor vanishes


class Ros2Settings(StrictStruct):
    """The `ros2:` section: how the session appears on the ROS 2 side."""

    domain_id: Annotated[int, msgspec.Meta(ge=0, le=232)] = 0  # ROS_DOMAIN_ID
    node_name: str = "carlaverse_bridge"
    prefix: str = "/carlaverse"  # the session's own topics sit under it
    map_frame: str = "map"
    rate_hz: Annotated[float, msgspec.Meta(gt=0, le=200)] = 20.0  # [Hz] world topics

    def __post_init__(self) -> None:
        check_node_name(self.node_name)
        check_topic(self.prefix, "prefix")
        if not self.map_frame or self.map_frame.startswith("/"):
            raise ValueError(f"map_frame {self.map_frame!r}: a frame id without a leading '/'")


class Ros2View:
    """Publishes a node's world view as ROS 2 topics (see the module docstring)."""

    def __init__(self, client: NodeClient, node: RosNode, settings: Ros2Settings) -> None:
        self.client = client
        self.node = node
        self.settings = settings
        prefix = settings.prefix
        self.clock = node.publisher("/clock", t.CLOCK)
        self.tf = node.publisher("/tf", t.TF_MESSAGE)
        self.objects = node.publisher(f"{prefix}/objects", t.DETECTION_3D_ARRAY)
        self.markers = node.publisher(f"{prefix}/markers", t.MARKER_ARRAY)
        self.lights = node.publisher(f"{prefix}/traffic_lights", t.TRAFFIC_LIGHT_ARRAY)
        self.odometry: dict[str, RosPublisher] = {}
        self.marker_ids: dict[str, int] = {}
        self.catalog = EgoCatalog(client)
        self.frames = 0
        self.publish_s: deque[float] = deque(maxlen=1000)  # [s] each frame's cost, newest
        self._lights_seq = -1

    def odometry_topic(self, ego_id: str) -> str:
        return f"{self.settings.prefix}/{ros_token(ego_id)}/odom"

    def publish(self, now: float) -> None:
        """Every topic once, for the world view as drawn at session time `now`."""
        started = time.perf_counter()
        self._publish(now)
        self.publish_s.append(time.perf_counter() - started)
        self.frames += 1

    def _publish(self, now: float) -> None:
        world, frame = self.client.world, self.settings.map_frame
        stamp_ns = round(now * 1e9)
        render_t = world.render_time(now)
        egos = [self._ego(view) for view in world.ego_views(now)]
        npc_frame = world.npc_frame(now)
        npcs = list(w.npc_states(npc_frame)) if npc_frame is not None else []
        actors = egos + npcs
        self.clock.publish(w.clock(now), stamp_ns)
        self.tf.publish(w.tf(actors, render_t, frame), stamp_ns)
        self._publish_odometry(egos, render_t, stamp_ns)
        self.objects.publish(w.detections(actors, render_t, frame), stamp_ns)
        life = MARKER_PERIODS / self.settings.rate_hz
        self.markers.publish(
            w.marker_array(actors, self.marker_ids, render_t, frame, life), stamp_ns
        )
        lights = world.lights
        if lights is not None and lights.seq != self._lights_seq:
            self._lights_seq = lights.seq
            self.lights.publish(w.traffic_lights(lights, frame), stamp_ns)

    def _ego(self, view: ActorView) -> w.ActorState:
        info = self.catalog.lookup(view.actor_id)
        if info is None:  # until the catalogue knows it: the kind its world view may have
            return w.ego_state(view, self.client.world.egos[view.actor_id].kind,
                               self._yaw_rate(view.actor_id))  # fmt: skip
        return w.ego_state(view, info[0], self._yaw_rate(view.actor_id), info[1])

    def _yaw_rate(self, ego_id: str) -> float:
        stream = self.client.world.streams.get(ego_id)
        newest = stream.newest if stream is not None else None
        return newest.wz if newest is not None else 0.0

    def _publish_odometry(self, egos: list[w.ActorState], time_s: float, stamp_ns: int) -> None:
        """An odometry topic per ego while it is present: its publisher (and graph token) is
        declared when the ego appears and undeclared when it goes."""
        present = {a.actor_id for a in egos}
        for gone in [ego for ego in self.odometry if ego not in present]:
            self.odometry.pop(gone).close()
        for a in egos:
            publisher = self.odometry.get(a.actor_id)
            if publisher is None:
                topic = self.odometry_topic(a.actor_id)
                publisher = self.odometry[a.actor_id] = self.node.publisher(topic, t.ODOMETRY)
            publisher.publish(w.odometry(a, time_s, self.settings.map_frame), stamp_ns)

    def close(self) -> None:
        for publisher in self.odometry.values():
            publisher.close()
        self.odometry.clear()

    def report(self) -> dict[str, Any]:
        """Frames published, what the ROS side sent that was dropped, and what a frame cost
        (building and encoding every topic) [ms]: median and worst of the newest 1000."""
        costs = sorted(self.publish_s)
        median = costs[len(costs) // 2] * 1e3 if costs else None
        worst = costs[-1] * 1e3 if costs else None
        return {"ros2_frames": self.frames, "ros2_dropped": self.node.dropped.snapshot(),
                "ros2_frame_ms_p50": median, "ros2_frame_ms_max": worst}  # fmt: skip


def next_due(due: float, now: float, period: float) -> float:
    """When to publish next: one period after the last due time, or after now when the
    loop fell a whole period behind (no burst to catch up)."""
    return due + period if now - due < period else now + period


class Ros2BridgeConfig(StrictStruct):
    # an observer to the authority: the one kind of node without an actor
    node: NodeSettings = NodeSettings(kind="observer", actor_kind="", interest_radius_m=0)
    fabric: FabricSettings = FabricSettings()
    ros2: Ros2Settings = Ros2Settings()


class Ros2BridgeNode:
    """A node without an actor that shows the whole session to ROS 2 (`carlaverse ros2 view`)."""

    name = "ros2"
    config_type = Ros2BridgeConfig

    def __init__(self, config: Ros2BridgeConfig) -> None:
        self.config = config
        self.view: Ros2View | None = None
        self._node: RosNode | None = None
        self._next_t = 0.0

    def pose_source(self) -> PoseSource | None:
        return None

    def step(self, client: NodeClient, now: float) -> None:
        if self.view is None:  # the session exists from the first step on
            s = self.config.ros2
            self._node = RosNode(client.session, s.node_name, domain=s.domain_id)
            self.view = Ros2View(client, self._node, s)
        if now >= self._next_t:
            self._next_t = next_due(self._next_t, now, 1.0 / self.config.ros2.rate_hz)
            self.view.publish(now)

    def close(self) -> None:
        if self.view is not None:
            self.view.close()
        if self._node is not None:
            self._node.close()

    def report(self) -> dict[str, Any]:
        return self.view.report() if self.view is not None else {}
