"""rmw_zenoh's keys, tokens and attachment as zenoh-ros2-sdk (written to rmw_zenoh's design,
sharing no code with carlaverse.ros2) builds and reads them; the AV participant's odometry
intake with a manual clock."""

from __future__ import annotations

import math

import pytest

from carlaverse.messages import Extent
from carlaverse.ros2 import keys as k
from carlaverse.ros2 import types as t
from carlaverse.ros2 import world_msgs as w
from carlaverse.ros2.av_participant import AvConfig, AvParticipantNode
from carlaverse.ros2.bridge import Ros2Settings, next_due

ZID = "7f3a0c1e9b2d4a58e6f1c0b3a2d4e5f6"


def test_the_data_key_is_the_sdks() -> None:
    from zenoh_ros2_sdk.keyexpr import topic_keyexpr
    from zenoh_ros2_sdk.utils import ros2_to_dds_type

    expected = topic_keyexpr(3, "/carlaverse/ego_1/odom", ros2_to_dds_type(t.ODOMETRY.name),
                             t.type_hash(t.ODOMETRY))  # fmt: skip
    assert k.data_key(3, "/carlaverse/ego_1/odom", t.ODOMETRY) == expected
    assert expected.startswith("3/carlaverse/ego_1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_")


def test_the_graph_tokens_are_the_sdks() -> None:
    from zenoh_ros2_sdk.entity import EndpointEntity, EntityKind, NodeEntity
    from zenoh_ros2_sdk.keyexpr import endpoint_liveliness_keyexpr, node_liveliness_keyexpr

    node = NodeEntity(domain_id=0, session_id=ZID, node_id=0, node_name="carlaverse_bridge")
    assert k.node_token(0, ZID, 0, "/", "carlaverse_bridge") == node_liveliness_keyexpr(node)
    publisher = EndpointEntity(node=node, entity_id=4, kind=EntityKind.PUBLISHER, name="/tf",
                               dds_type_name=t.dds_name(t.TF_MESSAGE),
                               type_hash=t.type_hash(t.TF_MESSAGE), qos=k.DEFAULT_QOS)  # fmt: skip
    ours = k.endpoint_token(0, ZID, 0, 4, "MP", "/", "carlaverse_bridge", "/tf", t.TF_MESSAGE)
    assert ours == endpoint_liveliness_keyexpr(publisher)


def test_the_qos_in_a_token_reads_as_ros2s_default_profile() -> None:
    """Reliable, volatile, keep last 10: what a ROS 2 node's default publisher says."""
    from zenoh_ros2_sdk.qos import QosProfile

    assert QosProfile.decode(k.DEFAULT_QOS) == QosProfile()


def test_the_attachment_reads_back_with_the_sdk() -> None:
    from zenoh_ros2_sdk.attachment import Attachment

    gid = bytes(range(16))
    read = Attachment.from_bytes(k.attachment(42, 1_700_000_000_123_456_789, gid))
    assert (read.sequence_id, read.timestamp_ns, read.gid) == (42, 1_700_000_000_123_456_789, gid)
    assert k.read_attachment(k.attachment(7, 9, gid)) == (7, 9, gid)
    with pytest.raises(ValueError, match="gid"):
        k.read_attachment(k.attachment(7, 9, gid)[:-1])


@pytest.mark.parametrize("bad", ["av/odom", "/av//odom", "/9av", "/av-1/odom", "/av/*", ""])
def test_a_topic_ros2_would_refuse_is_refused_with_the_rule(bad: str) -> None:
    with pytest.raises(k.RosNameError, match="fully qualified ROS 2 name"):
        k.check_topic(bad)


def test_node_ids_become_ros_tokens() -> None:
    assert k.ros_token("tum-drive-1") == "tum_drive_1"
    assert k.ros_token("1st.car") == "_1st_car"


def test_the_ros2_section_names_a_bad_value() -> None:
    with pytest.raises(ValueError, match="prefix"):
        Ros2Settings(prefix="carlaverse")
    with pytest.raises(ValueError, match="map_frame"):
        Ros2Settings(map_frame="/map")


def test_publishing_keeps_its_rate_without_bursting_after_a_stall() -> None:
    assert next_due(10.0, 10.01, 0.05) == pytest.approx(10.05)
    assert next_due(10.0, 11.0, 0.05) == pytest.approx(11.05)  # a stall: no catch-up burst


class ManualClock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def odometry(frame: str = "map", x: float = 3.0) -> dict:
    state = w.ActorState("av-1", "car", True, x, 4.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.1,
                         Extent())  # fmt: skip
    message = w.odometry(state, 0.0, "map")
    message["header"]["frame_id"] = frame
    return message


def test_the_av_sends_each_odometry_once_at_the_session_time_it_arrived() -> None:
    clock = ManualClock()
    node = AvParticipantNode(AvConfig(), monotonic=clock)
    assert node.pose_at(500.0) is None  # nothing heard yet
    node.on_odometry(odometry())
    clock.t += 0.1
    pose = node.pose_at(500.0)  # 0.1 s after it came, at session time 500
    assert pose is not None and pose.t == pytest.approx(499.9) and pose.x == pytest.approx(3.0)
    assert pose.yaw == pytest.approx(0.5) and pose.wz == pytest.approx(0.1)
    assert node.pose_at(500.02) is None  # the same odometry is not sent twice


def test_quiet_odometry_stops_the_poses() -> None:
    clock = ManualClock()
    node = AvParticipantNode(AvConfig(), monotonic=clock)
    node.on_odometry(odometry())
    clock.t += AvConfig().av.odom_timeout_s + 0.01
    assert node.pose_at(500.0) is None  # too old: the AV went quiet, the ego goes silent


def test_odometry_in_another_frame_or_broken_is_counted_and_dropped() -> None:
    node = AvParticipantNode(AvConfig(), monotonic=ManualClock())
    node.on_odometry(odometry(frame="odom"))
    broken = odometry()
    broken["pose"]["pose"]["position"]["x"] = math.inf
    node.on_odometry(broken)
    assert node.dropped.snapshot() == {"odom/frame": 1, "odom/value": 1}
    assert node.pose_at(1.0) is None and node.odometry_heard == 0


def test_the_av_config_refuses_an_unknown_actor_kind() -> None:
    import msgspec

    with pytest.raises(msgspec.ValidationError, match="actor_kind"):
        msgspec.convert({"node": {"actor_kind": "spaceship"}}, AvConfig)
