"""The independent ROS 2 side of the tests: zenoh-ros2-sdk, a ROS 2-over-Zenoh client written
to rmw_zenoh's design (its own keys, liveliness graph, QoS strings, type hashes), decoding with
rosbags' CDR -- no code of carlaverse.ros2 in it.

It works offline when every message definition it needs is in its messages folder: it looks
there first and only clones ROS repositories (GitPython) for a type it lacks. So the folder
is written here: the standard types from rosbags' ROS 2 Jazzy store (its copies of the .msg
files), vision_msgs and carlaverse_msgs from their .msg text below.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from rosbags.typesys import Stores, get_typestore

STANDARD = (
    "rosgraph_msgs/msg/Clock", "tf2_msgs/msg/TFMessage", "nav_msgs/msg/Odometry",
    "visualization_msgs/msg/MarkerArray",
)  # fmt: skip

# vision_msgs 4.x (ros-perception/vision_msgs, the ROS 2 branches), fields only.
VISION_MSGS = {
    "Detection3DArray": "std_msgs/Header header\nDetection3D[] detections\n",
    "Detection3D": "std_msgs/Header header\nObjectHypothesisWithPose[] results\n"
    "BoundingBox3D bbox\nstring id\n",
    "ObjectHypothesisWithPose": "ObjectHypothesis hypothesis\n"
    "geometry_msgs/PoseWithCovariance pose\n",
    "ObjectHypothesis": "string class_id\nfloat64 score\n",
    "BoundingBox3D": "geometry_msgs/Pose center\ngeometry_msgs/Vector3 size\n",
}
# carlaverse_msgs as docs/protocol.md gives them.
CARLAVERSE_MSGS = {
    "TrafficLight": "string id\nstring state\nint64 phase\nfloat64 remaining_s\n",
    "TrafficLightArray": "std_msgs/Header header\nTrafficLight[] lights\n",
    "CollisionImpulse": "std_msgs/Header header\nint64 contact_id\n"
    "geometry_msgs/Vector3 impulse\ngeometry_msgs/Point point\ngeometry_msgs/Vector3 normal\n"
    "string other_id\nstring other_kind\nfloat64 relative_speed_mps\n",
}


def write_messages(folder: Path) -> Path:
    """Every definition the tests' ROS side needs, as `<pkg>/msg/<Name>.msg` under `folder`."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for name in STANDARD:
        text, _ = store.generate_msgdef(name, ros_version=2)
        # the concatenated form: this type, then `MSG: pkg/Name` and each type it refers to
        for k, section in enumerate(text.split("=" * 80 + "\n")):
            if k == 0:
                own, body = name, section
            else:
                head, _, body = section.partition("\n")
                package, short = head.removeprefix("MSG: ").split("/")
                own = f"{package}/msg/{short}"
            _write(folder, own, body)
    for package, texts in (("vision_msgs", VISION_MSGS), ("carlaverse_msgs", CARLAVERSE_MSGS)):
        for short, body in texts.items():
            _write(folder, f"{package}/msg/{short}", body)
    return folder


def _write(folder: Path, name: str, body: str) -> None:
    path = folder / f"{name}.msg"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(body)


@contextmanager
def ros_side(port: int, folder: Path) -> Iterator[None]:
    """zenoh-ros2-sdk on a router at 127.0.0.1:`port`, its definitions in `folder`.

    The SDK keeps one session and one registry per process (module globals): both are made
    fresh here and dropped after, so each test has its own router."""
    from zenoh_ros2_sdk import message_registry
    from zenoh_ros2_sdk.session import ZenohSession

    write_messages(folder)
    message_registry._registry = None
    message_registry.get_registry(str(folder))
    ZenohSession.get_instance("127.0.0.1", port)
    try:
        yield
    finally:
        instance = ZenohSession._instance
        if instance is not None:
            instance.close()
        ZenohSession._instance = None
        message_registry._registry = None
