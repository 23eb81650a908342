"""Type names, RIHS01 hashes and CDR bytes against independent implementations.

Hashes: rosbags' ROS 2 Jazzy and Kilted stores and ros2-pyterfaces (each with its own copy of
the ROS definitions and its own hash code), zenoh-ros2-sdk's hash of the .msg text, and one
published value: rmw_zenoh's design doc keys std_msgs/String as
`0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c74...`. CDR: rosbags' serialiser (the one
zenoh-ros2-sdk decodes with) must produce the same bytes, and read ours back.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_typestore

from carlaverse.ros2 import cdr
from carlaverse.ros2 import types as t
from tests.ros2.ros_side import write_messages

STANDARD = [t.TIME, t.HEADER, t.CLOCK, t.TF_MESSAGE, t.ODOMETRY, t.MARKER, t.MARKER_ARRAY,
            t.TRANSFORM_STAMPED, t.POSE_COV]  # fmt: skip
OURS = [t.DETECTION_3D_ARRAY, t.TRAFFIC_LIGHT_ARRAY, t.COLLISION_IMPULSE]


# rmw_zenoh docs/design.md, "Topic and Service name mapping to Zenoh key expressions"
@functools.cache
def jazzy() -> Any:
    return get_typestore(Stores.ROS2_JAZZY)


STRING_HASH_PUBLISHED = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def test_the_hash_code_gives_the_published_hash_of_std_msgs_string() -> None:
    string = t.msg("std_msgs/msg/String", ("data", "string"))
    assert t.type_hash(string) == STRING_HASH_PUBLISHED
    assert t.dds_name(string) == "std_msgs::msg::dds_::String_"


@pytest.mark.parametrize("store", [Stores.ROS2_JAZZY, Stores.ROS2_KILTED])
@pytest.mark.parametrize("definition", STANDARD, ids=lambda d: d.name)
def test_standard_hashes_are_those_of_ros2(definition: t.MsgDef, store: Stores) -> None:
    assert t.type_hash(definition) == get_typestore(store).hash_rihs01(definition.name)


@pytest.mark.parametrize("definition", STANDARD, ids=lambda d: d.name)
def test_standard_hashes_agree_with_ros2_pyterfaces(definition: t.MsgDef) -> None:
    import importlib

    from ros2_pyterfaces.core import Sequence, hash_rihs01
    from ros2_pyterfaces.core.geometry_msgs.msg import TransformStamped

    package, _, short = definition.name.split("/")
    if package == "tf2_msgs":  # not among its packages: its one field, from tf2_msgs' .msg
        schema = {"__typename": definition.name, "transforms": Sequence(TransformStamped)}
    else:
        schema = getattr(importlib.import_module(f"ros2_pyterfaces.core.{package}.msg"), short)
    assert t.type_hash(definition) == hash_rihs01(schema)


@pytest.mark.parametrize("definition", STANDARD + OURS, ids=lambda d: d.name)
def test_hashes_agree_with_the_sdk_over_the_msg_text(definition: t.MsgDef, tmp_path: Path) -> None:
    """The SDK hashes the .msg files the ROS side uses (vision_msgs' text, carlaverse_msgs as
    documented), with its own parser and code: the same hash means the same type to ROS."""
    from zenoh_ros2_sdk.message_registry import MessageRegistry
    from zenoh_ros2_sdk.utils import compute_type_hash_from_msg, load_dependencies_recursive

    folder = write_messages(tmp_path)
    registry = MessageRegistry(str(folder))
    text = registry.get_msg_file_path(definition.name).read_text()  # type: ignore[union-attr]
    deps = load_dependencies_recursive(definition.name, text, registry)
    assert t.type_hash(definition) == compute_type_hash_from_msg(definition.name, text, deps)


def test_msg_text_is_the_documented_definition() -> None:
    assert t.msg_text(t.COLLISION_IMPULSE).splitlines()[:3] == [
        "std_msgs/Header header", "int64 contact_id", "geometry_msgs/Vector3 impulse",
    ]  # fmt: skip


ODOMETRY = {
    "header": {"stamp": {"sec": 1_700_000_000, "nanosec": 250_000_000}, "frame_id": "map"},
    "child_frame_id": "ego_1/base_link",
    "pose": {"pose": {"position": {"x": 12.5, "y": -3.0, "z": 0.25},
                      "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.3), "w": math.cos(0.3)}},
             "covariance": [0.01 * k for k in range(36)]},
    "twist": {"twist": {"linear": {"x": 8.0, "y": 0.1, "z": 0.0},
                        "angular": {"x": 0.0, "y": 0.0, "z": 0.2}}},
}  # fmt: skip
MARKERS = {"markers": [{
    "header": {"frame_id": "map"}, "ns": "npcs", "id": 7, "type": 1, "pose": {
        "orientation": {"w": 1.0}}, "scale": {"x": 4.5, "y": 1.8, "z": 1.5},
    "color": {"r": 0.25, "a": 1.0}, "lifetime": {"nanosec": 150_000_000}, "text": "vélo",
    "points": [{"x": 1.0}], "texture": {"data": b"\x01\x02\x03"},
}]}  # fmt: skip


@pytest.mark.parametrize(
    ("definition", "value"), [(t.ODOMETRY, ODOMETRY), (t.MARKER_ARRAY, MARKERS)],
    ids=["odometry", "markers"],
)  # fmt: skip
def test_cdr_bytes_are_rosbags_bytes(definition: t.MsgDef, value: dict) -> None:
    store = get_typestore(Stores.ROS2_JAZZY)
    ours = cdr.encode(definition, value)
    theirs = store.deserialize_cdr(ours, definition.name)  # rosbags reads ours ...
    assert bytes(store.serialize_cdr(theirs, definition.name)) == ours  # ... and writes the same
    assert cdr.decode(definition, ours) == cdr.decode(definition, bytes(ours))
    again = cdr.decode(definition, ours)
    assert again["child_frame_id" if "child_frame_id" in again else "markers"]
    assert cdr.encode(definition, again) == ours  # decode is encode's inverse


def test_rosbags_odometry_decodes_to_the_same_values() -> None:
    store = get_typestore(Stores.ROS2_JAZZY)
    message = store.deserialize_cdr(cdr.encode(t.ODOMETRY, ODOMETRY), "nav_msgs/msg/Odometry")
    assert message.header.stamp.sec == 1_700_000_000
    assert message.header.stamp.nanosec == 250_000_000
    assert message.child_frame_id == "ego_1/base_link"
    assert message.pose.pose.orientation.z == pytest.approx(math.sin(0.3))
    assert list(message.pose.covariance) == pytest.approx([0.01 * k for k in range(36)])
    assert message.twist.twist.angular.z == 0.2


def test_a_payload_without_the_cdr_le_header_is_refused_by_name() -> None:
    payload = b"\x00\x00\x00\x00" + cdr.encode(t.CLOCK, {})[4:]  # big-endian CDR
    with pytest.raises(cdr.CdrError, match="rosgraph_msgs/msg/Clock: encapsulation"):
        cdr.decode(t.CLOCK, payload)


def test_a_truncated_payload_names_the_field() -> None:
    payload = cdr.encode(t.ODOMETRY, ODOMETRY)
    with pytest.raises(cdr.CdrError, match=r"nav_msgs/msg/Odometry\.twist"):
        cdr.decode(t.ODOMETRY, payload[:-8])


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=400))
def test_hostile_bytes_raise_only_cdr_error(raw: bytes) -> None:
    for definition in (t.ODOMETRY, t.MARKER_ARRAY):
        try:
            cdr.decode(definition, cdr.ENCAPSULATION_LE + raw)
        except cdr.CdrError:
            pass


@settings(max_examples=60, deadline=None)
@given(
    ns=st.text(max_size=9), text=st.text(max_size=7), points=st.integers(0, 3),
    data=st.binary(max_size=5), frame=st.text(max_size=6), sec=st.integers(-(2**31), 2**31 - 1),
)  # fmt: skip
def test_every_padding_matches_rosbags(
    ns: str, text: str, points: int, data: bytes, frame: str, sec: int
) -> None:
    """Strings and sequences of every length move the doubles after them to every offset
    modulo 8: rosbags must read each payload and write the same bytes back."""
    store = jazzy()
    marker = {
        "header": {"stamp": {"sec": sec}, "frame_id": frame},
        "ns": ns,
        "text": text,
        "id": -3,
        "frame_locked": True,
        "pose": {"position": {"x": 1.5, "z": -2.0}},
        "points": [{"x": float(k), "y": -1.0} for k in range(points)],
        "texture": {"format": frame, "data": data},
        "mesh_file": {"filename": text},
    }
    ours = cdr.encode(t.MARKER_ARRAY, {"markers": [marker, marker]})
    theirs = store.deserialize_cdr(ours, "visualization_msgs/msg/MarkerArray")
    assert bytes(store.serialize_cdr(theirs, "visualization_msgs/msg/MarkerArray")) == ours
    assert theirs.markers[1].ns == ns and theirs.markers[1].pose.position.z == -2.0


def test_cdr_bytes_are_ros2_pyterfaces_bytes() -> None:
    """ros2-pyterfaces' own serialiser (cydr, compiled on first use: skipped without it) writes
    the same bytes, down to the defaults ROS gives a field left out (a Quaternion's w is 1)."""
    pytest.importorskip("cydr", reason="ros2-pyterfaces' CDR backend (pip install cydr)")
    import numpy as np
    from ros2_pyterfaces.cydr.builtin_interfaces.msg import Time
    from ros2_pyterfaces.cydr.nav_msgs.msg import Odometry
    from ros2_pyterfaces.cydr.std_msgs.msg import Header

    assert cdr.encode(t.ODOMETRY, {}) == bytes(Odometry().serialize())
    stamp = Time(sec=np.int32(1_700_000_000), nanosec=np.uint32(250_000_000))
    header = Header(stamp=stamp, frame_id=b"map")
    theirs = Odometry(header=header, child_frame_id=b"ego_1/base_link")
    theirs.pose.pose.position.x = np.float64(12.5)
    theirs.pose.pose.orientation.z = np.float64(math.sin(0.3))
    theirs.pose.pose.orientation.w = np.float64(math.cos(0.3))
    theirs.pose.covariance[:] = [0.01 * k for k in range(36)]
    theirs.twist.twist.linear.x = np.float64(8.0)
    ours = {
        "header": {"stamp": {"sec": 1_700_000_000, "nanosec": 250_000_000}, "frame_id": "map"},
        "child_frame_id": "ego_1/base_link",
        "pose": {"pose": {"position": {"x": 12.5},
                          "orientation": {"z": math.sin(0.3), "w": math.cos(0.3)}},
                 "covariance": [0.01 * k for k in range(36)]},
        "twist": {"twist": {"linear": {"x": 8.0}}},
    }  # fmt: skip
    assert cdr.encode(t.ODOMETRY, ours) == bytes(theirs.serialize())
