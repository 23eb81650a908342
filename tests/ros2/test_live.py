"""The ROS 2 view and the AV participant end to end: a router, an authority, the `carlaverse
ros2` command as its own process, and zenoh-ros2-sdk (tests/ros2/ros_side.py) as the ROS 2
side -- it lists the graph from rmw_zenoh's liveliness tokens and decodes with rosbags.
"""

from __future__ import annotations

import math
import threading
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from carlaverse import messages as m
from carlaverse.procs import free_port
from carlaverse.ros2 import types as ros_types
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.ros2.ros_side import ros_side
from tests.support import Cluster, _accepts, wait_until

SPEED_MPS = 10.0
CAR = m.Extent()
YAW_RATE = 0.2  # [rad/s] turning left: counter-clockwise seen from above
NORTH_EAST = math.pi / 4  # [rad] from east toward north
# [rad/s] the view's ego turns left slowly: its drawn yaw, projected ahead by up to 0.5 s,
# stays within 0.01 rad of north-east
SLOW_LEFT = 0.02

VIEW_TOPICS = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/carlaverse/objects": "vision_msgs/msg/Detection3DArray",
    "/carlaverse/markers": "visualization_msgs/msg/MarkerArray",
    "/carlaverse/traffic_lights": "carlaverse_msgs/msg/TrafficLightArray",
    "/carlaverse/ego_1/odom": "nav_msgs/msg/Odometry",
}


def north_east_pose(t: float) -> m.Pose:
    """Heading north-east (yaw π/4: the session's yaw is counter-clockwise from east) at
    10 m/s, turning left; the position is the start's, the velocity what matters here."""
    v = SPEED_MPS * math.sqrt(0.5)
    return m.Pose(0, t, 100.0, 50.0, 0.0, 0.0, 0.0, NORTH_EAST, v, v, 0.0, 0.0, 0.0,
                  SLOW_LEFT)  # fmt: skip


def npc_batch(seq: int, t: float) -> m.NpcBatch:
    rows = np.zeros(1, dtype=m.NPC_DTYPE)
    rows[0] = (120.0, 40.0, 0.0, math.pi / 2, 0.0, 5.0, 0.0, 4.0, 1.8, 1.5,
               m.ACTOR_KINDS.index("van"), 0, 0)  # fmt: skip
    return m.NpcBatch.pack(seq, t, ["npc-7"], rows)


def ego_client(
    cluster: Cluster, node_id: str, source: Any, kind: str = "car", extent: m.Extent = CAR
) -> NodeClient:
    session = open_session(FabricSettings(connect=[cluster.endpoint]))
    cluster.sessions.append(session)
    settings = NodeSettings(node_id=node_id, session="t", kind="scripted", actor_kind=kind,
                            extent=extent)  # fmt: skip
    client = NodeClient(session, settings, MonotonicClock()).start(pose_source=source)
    cluster.sessions.append(client)
    return client


class Heard:
    """Messages the ROS side decoded, by topic (zenoh-ros2-sdk's callbacks append here)."""

    def __init__(self) -> None:
        self.by_topic: dict[str, list[Any]] = defaultdict(list)
        self.subscribers: list[Any] = []

    def subscribe(self, port: int, topic: str, msg_type: str) -> None:
        from zenoh_ros2_sdk import ROS2Subscriber

        self.subscribers.append(ROS2Subscriber(
            topic, msg_type, self.by_topic[topic].append, router_port=port,
        ))  # fmt: skip

    def last(self, topic: str) -> Any:
        return self.by_topic[topic][-1] if self.by_topic[topic] else None

    def close(self) -> None:
        for subscriber in self.subscribers:
            subscriber.close()


def listed_topics(port: int) -> dict[str, list[str]]:
    from zenoh_ros2_sdk import get_topic_names_and_types

    return dict(get_topic_names_and_types(router_port=port, timeout=0.5))


def test_the_session_as_ros2_topics(cluster: Cluster, tmp_path: Path) -> None:
    cluster.router()
    outbox = cluster.in_process_authority().start().outbox
    ego = ego_client(cluster, "ego-1", north_east_pose)
    view = cluster.start("ros2", "view", "--session", "t", "--connect", cluster.endpoint,
                         "--duration", "40", "--json", name="ros2-view")  # fmt: skip
    # The ROS side on a router of its own connected to the session's, as docs/protocol.md
    # tells a ROS host to run rmw_zenohd.
    ros_port = free_port()
    ros_router = cluster.start("router", "--listen", f"tcp/127.0.0.1:{ros_port}", "--connect",
                               cluster.endpoint, name="ros-router")  # fmt: skip
    wait_until(lambda: _accepts(ros_port) or not ros_router.alive(), 30, "the ROS router")
    heard = Heard()
    seq = iter(range(1, 10**6))

    def world_goes_on() -> None:  # NPCs and lights, as a traffic engine would send them
        t = ego.now()
        outbox.npc(npc_batch(next(seq), t))
        outbox.lights(m.LightsState(next(seq), t, [m.TrafficLight("J1", "GrGr", 2, 4.5)]))

    with ros_side(ros_port, tmp_path / "msgs"):
        try:
            # `ros2 topic list -t`: every topic with its type, from the liveliness graph
            def all_listed() -> bool:
                world_goes_on()
                topics = listed_topics(ros_port)
                return all(topics.get(n) == [ty] for n, ty in VIEW_TOPICS.items())

            wait_until(all_listed, 30, f"the ROS graph to list {VIEW_TOPICS}", poll=0.2)
            for topic, msg_type in VIEW_TOPICS.items():
                heard.subscribe(ros_port, topic, msg_type)

            def every_topic_heard() -> bool:
                world_goes_on()
                return all(heard.by_topic[topic] for topic in VIEW_TOPICS) and any(
                    len(tf.transforms) == 2 for tf in heard.by_topic["/tf"]
                )

            wait_until(every_topic_heard, 20, "a message on every topic", poll=0.1)
            _check_view_messages(heard, ego.now())
            # an ego that joins after the view: its kind and box come from the authority
            truck = m.KIND_EXTENTS["truck"]
            ego_client(cluster, "ego-2", north_east_pose, "truck", truck)

            def truck_box() -> Any:
                objects = heard.last("/carlaverse/objects")
                return next((d for d in objects.detections if d.id == "ego-2"), None)

            late = wait_until(lambda: (d := truck_box()) and d.bbox.size.x == truck.length and d,
                              10, "the late ego's own box")  # fmt: skip
            assert late.results[0].hypothesis.class_id == "truck"
            size = late.bbox.size
            assert (size.x, size.y, size.z) == (truck.length, truck.width, truck.height)
        finally:
            heard.close()
    assert view.stop() == 0, view.output()[-3000:]
    report = view.json()["extra"]
    assert report["ros2_frames"] > 0 and report["ros2_dropped"] == {}
    assert 0 < report["ros2_frame_ms_p50"] <= report["ros2_frame_ms_max"]


def _check_view_messages(heard: Heard, now: float) -> None:
    clock = heard.last("/clock").clock
    assert abs(clock.sec + clock.nanosec * 1e-9 - now) < 2.0  # session time, Unix-aligned
    odom = heard.last("/carlaverse/ego_1/odom")
    assert (odom.header.frame_id, odom.child_frame_id) == ("map", "ego_1/base_link")
    q = odom.pose.pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))  # REP 103 yaw
    assert abs(yaw - NORTH_EAST) < 0.02 and yaw > 0
    # Forward at 10 m/s in its own frame (the view draws between samples: a few % off)
    assert abs(odom.twist.twist.linear.x - SPEED_MPS) < 0.5
    assert abs(odom.twist.twist.linear.y) < 0.5
    assert abs(odom.twist.twist.angular.z - SLOW_LEFT) < 1e-3  # left turn: positive
    tf = next(tf for tf in reversed(heard.by_topic["/tf"]) if len(tf.transforms) == 2)
    frames = {t.child_frame_id: t for t in tf.transforms}
    assert set(frames) == {"ego_1/base_link", "npc_7/base_link"}
    assert all(t.header.frame_id == "map" for t in tf.transforms)
    npc = frames["npc_7/base_link"].transform
    # driving north at 5 m/s from (120, 40): drawn within half a second of a batch
    assert abs(npc.translation.x - 120.0) < 1e-3 and abs(npc.translation.y - 40.0) < 2.6
    objects = heard.last("/carlaverse/objects")
    kinds = {d.id: d.results[0].hypothesis.class_id for d in objects.detections}
    assert kinds.get("npc-7") == "van" and "ego-1" in kinds
    van = next(d for d in objects.detections if d.id == "npc-7")
    size = (van.bbox.size.x, van.bbox.size.y, van.bbox.size.z)
    assert size == (4.0, float(np.float32(1.8)), 1.5)  # the batch's float32 extents
    assert van.bbox.center.position.z == 0.75  # the box stands on the road: half its height
    markers = heard.last("/carlaverse/markers").markers
    assert {mk.ns for mk in markers} <= {"egos", "npcs"} and all(mk.type == 1 for mk in markers)
    lights = heard.last("/carlaverse/traffic_lights").lights
    assert [(li.id, li.state, li.phase, li.remaining_s) for li in lights] == [
        ("J1", "GrGr", 2, 4.5)
    ]


def odometry_message(store: Any, t: float, x: float, y: float, yaw: float) -> Any:
    """nav_msgs/Odometry as an AV stack sends it, built from rosbags' classes alone: the pose
    in `map`, the twist in the vehicle's frame (forward SPEED_MPS, turning left)."""
    T = store.types
    stamp = T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=int((t % 1) * 1e9))
    point, vector = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Vector3"]
    quaternion = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2),
                                                   w=math.cos(yaw / 2))  # fmt: skip
    pose = T["geometry_msgs/msg/Pose"](position=point(x=x, y=y, z=0.0), orientation=quaternion)
    twist = T["geometry_msgs/msg/Twist"](linear=vector(x=SPEED_MPS, y=0.0, z=0.0),
                                         angular=vector(x=0.0, y=0.0, z=YAW_RATE))  # fmt: skip
    covariance = np.zeros(36)
    return {
        "header": T["std_msgs/msg/Header"](stamp=stamp, frame_id="map"),
        "child_frame_id": "av/base_link",
        "pose": T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=covariance),
        "twist": T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=covariance),
    }


class PathDriver:
    """The ROS side drives a left-hand circle (10 m/s, 0.2 rad/s: radius 50 m) and publishes
    its odometry at 20 Hz until stopped."""

    def __init__(self, port: int) -> None:
        from zenoh_ros2_sdk import ROS2Publisher

        self.publisher = ROS2Publisher("/av/odom", "nav_msgs/msg/Odometry", router_port=port)
        self.store = self.publisher.session_mgr.store
        self.sent: list[tuple[float, float, float]] = []  # (x, y, yaw)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._drive, daemon=True)
        self.thread.start()

    def _drive(self) -> None:
        k = 0
        while not self.stop.wait(0.05):
            s = k * 0.05
            yaw = YAW_RATE * s
            radius = SPEED_MPS / YAW_RATE
            x, y = radius * math.sin(yaw), radius * (1 - math.cos(yaw))
            self.publisher.publish(**odometry_message(self.store, 1.7e9 + s, x, y, yaw))
            self.sent.append((x, y, yaw))
            k += 1

    def close(self) -> None:
        self.stop.set()
        self.thread.join(2)
        self.publisher.close()


def test_a_ros2_av_drives_in_the_session(cluster: Cluster, tmp_path: Path) -> None:
    cluster.router()
    authority = cluster.in_process_authority()
    outbox = authority.start().outbox
    av = cluster.start(
        "ros2", "av", "--id", "av-1", "--session", "t", "--connect", cluster.endpoint,
        "--odom-topic", "/av/odom", "--actor-kind", "van", "--extent", "5.0,2.0,2.2",
        "--duration", "40", "--json", name="ros2-av",
    )  # fmt: skip
    obs = cluster.observer()
    heard = Heard()
    with ros_side(cluster.port, tmp_path / "msgs"):
        # `ros2 topic list -t` shows the AV listening for its odometry; it joins the session
        # only once the odometry comes, and then its collisions topic is listed too
        odom = {"/av/odom": ["nav_msgs/msg/Odometry"]}
        wait_until(lambda: odom.items() <= listed_topics(cluster.port).items(), 30,
                   "the AV's odometry subscription in the ROS graph", poll=0.2)  # fmt: skip
        assert "av-1" not in {e.node_id for e in m.SNAPSHOT.decode(obs.query("snapshot")).egos}
        driver = PathDriver(cluster.port)
        try:
            collisions = {"/carlaverse/av_1/collisions": ["carlaverse_msgs/msg/CollisionImpulse"]}
            wait_until(lambda: collisions.items() <= listed_topics(cluster.port).items(), 30,
                       "the AV's collisions topic in the ROS graph", poll=0.2)  # fmt: skip
            heard.subscribe(cluster.port, "/carlaverse/av_1/collisions",
                            "carlaverse_msgs/msg/CollisionImpulse")  # fmt: skip
            heard.subscribe(cluster.port, "/clock", "rosgraph_msgs/msg/Clock")

            def av_seen() -> Any:
                obs.update()
                actor = obs.world.egos.get("av-1")
                return actor is not None and actor.newest is not None and len(driver.sent) > 30

            wait_until(av_seen, 30, "the AV in the observer's world", poll=0.05)
            # bytes that are no Odometry on its topic: counted and dropped, never raised
            odom = ros_types.ODOMETRY
            junk_key = f"0/av/odom/{ros_types.dds_name(odom)}/{ros_types.type_hash(odom)}"
            driver.publisher.session_mgr.session.put(junk_key, b"\x00\x01\x00\x00junk")
            _check_av_follows_the_path(obs, driver)
            snapshot = m.SNAPSHOT.decode(obs.query("snapshot"))
            info = next(e for e in snapshot.egos if e.node_id == "av-1")
            assert (info.kind, info.actor_kind) == ("ros2-av", "van")
            assert info.extent == m.Extent(5.0, 2.0, 2.2)
            # its collisions come back as a topic
            impulse = m.Impulse(1, obs.now(), 11, (-300.0, 150.0, 0.0), (1.0, 2.0, 0.5),
                                (-0.89, 0.45, 0.0), "npc-3", "car", 4.2)  # fmt: skip
            wait_until(lambda: heard.by_topic["/clock"], 10, "the world topics of the AV")
            outbox.impulse("av-1", impulse)
            got = wait_until(lambda: heard.last("/carlaverse/av_1/collisions"), 10,
                             "the collision on the AV's topic")  # fmt: skip
            assert (got.contact_id, got.other_id, got.other_kind) == (11, "npc-3", "car")
            assert (got.impulse.x, got.impulse.y, got.impulse.z) == (-300.0, 150.0, 0.0)
            assert (got.normal.x, got.normal.y) == (-0.89, 0.45)
            assert got.header.frame_id == "map" and got.relative_speed_mps == 4.2
        finally:
            driver.close()
            heard.close()
        # silent AV: despawned by the same rule as any silent node (despawn timeout 3 s)
        wait_until(lambda: _despawned(obs, "av-1"), 15, "the silent AV's despawn", poll=0.1)
        # ... and back when its odometry is: the node joined again meanwhile
        gone_t = next(d.t for d in obs.world.despawns if d.actor_id == "av-1")
        driver = PathDriver(cluster.port)

        def back() -> bool:
            obs.update()
            actor = obs.world.egos.get("av-1")
            return actor is not None and actor.newest is not None and actor.newest.t > gone_t

        try:
            wait_until(back, 15, "the AV back in the observer's world", poll=0.05)
        finally:
            driver.close()
    assert av.stop() == 0
    report = av.json()["extra"]
    assert report["odometry_heard"] >= 15 and report["impulses_sent"] == 1
    assert report["odometry_dropped"] == {"/av/odom": 1}


def _check_av_follows_the_path(obs: NodeClient, driver: PathDriver) -> None:
    """The newest pose the observer has is one the AV drove: on the circle, heading along it."""
    pose = obs.world.egos["av-1"].newest
    assert pose is not None
    x, y, yaw = min(driver.sent, key=lambda s: math.hypot(s[0] - pose.x, s[1] - pose.y))
    assert math.hypot(x - pose.x, y - pose.y) < 0.01  # float32 on the wire: mm
    assert abs(pose.yaw - yaw) < 1e-3
    # the twist was forward in the AV's frame: in the world it is along the heading
    assert abs(math.hypot(pose.vx, pose.vy) - SPEED_MPS) < 1e-3
    assert abs(math.atan2(pose.vy, pose.vx) - yaw) < 1e-3
    assert abs(pose.wz - YAW_RATE) < 1e-3  # a left turn stays positive


def _despawned(obs: NodeClient, node_id: str) -> bool:
    obs.update()
    return any(d.actor_id == node_id and d.reason == "timeout" for d in obs.world.despawns)
