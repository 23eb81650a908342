"""Signs of the session-to-ROS conversion, each expected value derived without our code.

REP 103: the map frame is ENU (x east, y north, z up); a body frame has x forward, y left,
z up; rotations are right-handed, so yaw is counter-clockwise seen from above. The session's
world frame is also x east, y north (carlaverse/messages/pose.py) with yaw counter-clockwise from
+x, roll right-side-down positive and pitch nose-down positive (ISO 8855). The quaternions are
read with scipy's Rotation, which shares no code with carlaverse.ros2.frames.
"""

from __future__ import annotations

import math

import pytest
from scipy.spatial.transform import Rotation

from carlaverse import messages as m
from carlaverse.ros2 import frames
from carlaverse.ros2 import world_msgs as w

NORTH_EAST = math.pi / 4  # [rad] from east toward north


def actor(yaw: float = 0.0, vx: float = 0.0, vy: float = 0.0, yaw_rate: float = 0.0,
          roll: float = 0.0, pitch: float = 0.0) -> w.ActorState:  # fmt: skip
    return w.ActorState("ego-1", "car", True, 10.0, 20.0, 0.5, roll, pitch, yaw, vx, vy,
                        0.0, yaw_rate, m.Extent())  # fmt: skip


def rotation_of(message_pose: dict) -> Rotation:
    q = message_pose["orientation"]
    return Rotation.from_quat([q["x"], q["y"], q["z"], q["w"]])


def test_an_actor_heading_north_east_points_its_x_axis_north_east_with_positive_yaw() -> None:
    odom = w.odometry(actor(yaw=NORTH_EAST), 0.0, "map")
    r = rotation_of(odom["pose"]["pose"])
    # its nose (body +x) points half east, half north in the ENU map frame
    assert r.apply([1.0, 0.0, 0.0]) == pytest.approx([math.sqrt(0.5), math.sqrt(0.5), 0.0])
    yaw = r.as_euler("ZYX")[0]
    assert yaw == pytest.approx(NORTH_EAST) and yaw > 0
    assert odom["pose"]["pose"]["position"] == {"x": 10.0, "y": 20.0, "z": 0.5}  # ENU as is


def test_the_twist_is_in_the_body_frame() -> None:
    """Driving north-east at 10 m/s is 10 m/s forward, nothing sideways (REP 105: twist in
    the child frame); moving north while facing east is moving to the left, +y."""
    v = 10.0 * math.sqrt(0.5)
    linear = w.odometry(actor(yaw=NORTH_EAST, vx=v, vy=v), 0.0, "map")["twist"]["twist"]["linear"]
    assert (linear["x"], linear["y"], linear["z"]) == pytest.approx((10.0, 0.0, 0.0))
    sideways = w.odometry(actor(yaw=0.0, vy=2.0), 0.0, "map")["twist"]["twist"]["linear"]
    assert sideways["y"] == pytest.approx(2.0) and sideways["x"] == pytest.approx(0.0)


def test_turning_left_is_a_positive_angular_z() -> None:
    """Left is counter-clockwise seen from above: by the right-hand rule about +z, positive."""
    turning = w.odometry(actor(yaw=1.0, yaw_rate=0.3), 0.0, "map")
    assert turning["twist"]["twist"]["angular"]["z"] == pytest.approx(0.3)


def test_pitch_nose_down_and_roll_right_side_down_as_ros_sees_them() -> None:
    nose_down = rotation_of(w.odometry(actor(pitch=0.1), 0.0, "map")["pose"]["pose"])
    assert nose_down.apply([1.0, 0.0, 0.0])[2] == pytest.approx(-math.sin(0.1))  # nose below
    right_down = rotation_of(w.odometry(actor(roll=0.1), 0.0, "map")["pose"]["pose"])
    assert right_down.apply([0.0, -1.0, 0.0])[2] == pytest.approx(-math.sin(0.1))  # right side


def test_odometry_turns_back_into_the_same_world_pose() -> None:
    original = actor(yaw=2.5, vx=-3.0, vy=4.0, yaw_rate=-0.2, roll=0.05, pitch=-0.04)
    pose = w.pose_from_odometry(w.odometry(original, 0.0, "map"), 42.0)
    assert pose.t == 42.0
    assert (pose.x, pose.y, pose.z) == pytest.approx((10.0, 20.0, 0.5))
    assert (pose.roll, pose.pitch, pose.yaw) == pytest.approx((0.05, -0.04, 2.5))
    assert (pose.vx, pose.vy, pose.vz) == pytest.approx((-3.0, 4.0, 0.0), abs=1e-12)
    assert pose.wz == pytest.approx(-0.2)


def test_odometry_out_of_range_or_not_finite_is_refused() -> None:
    odom = w.odometry(actor(), 0.0, "map")
    odom["twist"]["twist"]["linear"]["x"] = math.nan
    with pytest.raises(ValueError, match="not finite"):
        w.pose_from_odometry(odom, 0.0)
    odom = w.odometry(actor(), 0.0, "map")
    odom["pose"]["pose"]["position"]["x"] = 1e9
    with pytest.raises(ValueError, match="out of range"):
        w.pose_from_odometry(odom, 0.0)
    odom["pose"]["pose"]["orientation"] = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
    with pytest.raises(ValueError, match="no direction"):
        w.pose_from_odometry(odom, 0.0)


def test_stamps_split_session_seconds_into_sec_and_nanosec() -> None:
    assert frames.stamp(1_700_000_000.25) == {"sec": 1_700_000_000, "nanosec": 250_000_000}
    assert frames.stamp(-0.5) == {"sec": -1, "nanosec": 500_000_000}  # ROS: nanosec >= 0
    assert frames.seconds(frames.stamp(12.125)) == 12.125
