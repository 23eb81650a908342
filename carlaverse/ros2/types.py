"""ROS 2 message definitions this package speaks, and their type names and hashes.

A definition is the field list of its `.msg` file (constants left out: they travel nowhere
and take no part in the hash). From it come the two names rmw_zenoh puts in a key:

    dds_name(ODOMETRY)   'nav_msgs::msg::dds_::Odometry_'
    type_hash(ODOMETRY)  'RIHS01_3cc97dc7...'

`type_hash` is REP 2011's RIHS01: SHA-256 of the type description (the type and every type
it refers to, by name, sorted) written as JSON the way `rosidl_generator_type_description`
writes it, default values left out. tests/ros2/test_types.py holds each hash to what two
independent libraries compute from their own copies of the ROS 2 Jazzy/Kilted definitions.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import cache
from typing import Any, Literal

# CDR size [bytes] of each primitive; its alignment is the same.
PRIMITIVE_SIZES: dict[str, int] = {
    "bool": 1, "byte": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4,
    "uint32": 4, "int64": 8, "uint64": 8, "float32": 4, "float64": 8,
}  # fmt: skip
PRIMITIVES = (*PRIMITIVE_SIZES, "string")

# type_description_interfaces/msg/FieldType: the id of each primitive, and how a collection
# moves it (a fixed array +48, a bounded sequence +96, an unbounded sequence +144).
_TYPE_IDS = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
    "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "bool": 15, "byte": 16, "string": 17,
}  # fmt: skip
_ARRAY_SHIFT = 48
_SEQUENCE_SHIFT = 144

Collection = Literal["single", "array", "sequence"]


@dataclass(frozen=True)
class Field:
    name: str
    type: str | MsgDef  # a primitive's name, or a nested message
    collection: Collection = "single"
    size: int = 0  # elements of a fixed array
    default: float = 0  # a primitive's value when a message leaves it out (the .msg default)

    @property
    def nested(self) -> MsgDef | None:
        return self.type if isinstance(self.type, MsgDef) else None


@dataclass(frozen=True)
class MsgDef:
    name: str  # 'nav_msgs/msg/Odometry'
    fields: tuple[Field, ...]


def msg(name: str, *fields: tuple[Any, ...]) -> MsgDef:
    """A definition from `(name, type)`, `(name, type, "sequence")`,
    `(name, type, "array", size)` or `(name, type, "single", 0, default)` tuples, in the
    `.msg` file's order."""
    return MsgDef(name, tuple(Field(*f) for f in fields))


def dds_name(definition: MsgDef) -> str:
    """The DDS/rmw_zenoh spelling: 'nav_msgs::msg::dds_::Odometry_'."""
    package, kind, short = definition.name.split("/")
    return f"{package}::{kind}::dds_::{short}_"


# --------------------------------------------------------------------------- definitions

TIME = msg("builtin_interfaces/msg/Time", ("sec", "int32"), ("nanosec", "uint32"))
DURATION = msg("builtin_interfaces/msg/Duration", ("sec", "int32"), ("nanosec", "uint32"))
HEADER = msg("std_msgs/msg/Header", ("stamp", TIME), ("frame_id", "string"))
COLOR = msg("std_msgs/msg/ColorRGBA", ("r", "float32"), ("g", "float32"), ("b", "float32"),
            ("a", "float32"))  # fmt: skip
POINT = msg("geometry_msgs/msg/Point", ("x", "float64"), ("y", "float64"), ("z", "float64"))
VECTOR3 = msg("geometry_msgs/msg/Vector3", ("x", "float64"), ("y", "float64"), ("z", "float64"))
QUATERNION = msg("geometry_msgs/msg/Quaternion", ("x", "float64"), ("y", "float64"),
                 ("z", "float64"), ("w", "float64", "single", 0, 1))  # fmt: skip
POSE = msg("geometry_msgs/msg/Pose", ("position", POINT), ("orientation", QUATERNION))
TWIST = msg("geometry_msgs/msg/Twist", ("linear", VECTOR3), ("angular", VECTOR3))
POSE_COV = msg("geometry_msgs/msg/PoseWithCovariance", ("pose", POSE),
               ("covariance", "float64", "array", 36))  # fmt: skip
TWIST_COV = msg("geometry_msgs/msg/TwistWithCovariance", ("twist", TWIST),
                ("covariance", "float64", "array", 36))  # fmt: skip
TRANSFORM = msg("geometry_msgs/msg/Transform", ("translation", VECTOR3), ("rotation", QUATERNION))
TRANSFORM_STAMPED = msg("geometry_msgs/msg/TransformStamped", ("header", HEADER),
                        ("child_frame_id", "string"), ("transform", TRANSFORM))  # fmt: skip
TF_MESSAGE = msg("tf2_msgs/msg/TFMessage", ("transforms", TRANSFORM_STAMPED, "sequence"))
ODOMETRY = msg("nav_msgs/msg/Odometry", ("header", HEADER), ("child_frame_id", "string"),
               ("pose", POSE_COV), ("twist", TWIST_COV))  # fmt: skip
CLOCK = msg("rosgraph_msgs/msg/Clock", ("clock", TIME))

COMPRESSED_IMAGE = msg("sensor_msgs/msg/CompressedImage", ("header", HEADER),
                       ("format", "string"), ("data", "uint8", "sequence"))  # fmt: skip
UV_COORDINATE = msg("visualization_msgs/msg/UVCoordinate", ("u", "float32"), ("v", "float32"))
MESH_FILE = msg("visualization_msgs/msg/MeshFile", ("filename", "string"),
                ("data", "uint8", "sequence"))  # fmt: skip
MARKER = msg(
    "visualization_msgs/msg/Marker",
    ("header", HEADER), ("ns", "string"), ("id", "int32"), ("type", "int32"),
    ("action", "int32"), ("pose", POSE), ("scale", VECTOR3), ("color", COLOR),
    ("lifetime", DURATION), ("frame_locked", "bool"), ("points", POINT, "sequence"),
    ("colors", COLOR, "sequence"), ("texture_resource", "string"),
    ("texture", COMPRESSED_IMAGE), ("uv_coordinates", UV_COORDINATE, "sequence"),
    ("text", "string"), ("mesh_resource", "string"), ("mesh_file", MESH_FILE),
    ("mesh_use_embedded_materials", "bool"),
)  # fmt: skip
MARKER_ARRAY = msg("visualization_msgs/msg/MarkerArray", ("markers", MARKER, "sequence"))
MARKER_CUBE = 1  # visualization_msgs/Marker constants
MARKER_ADD = 0
MARKER_DELETEALL = 3

# vision_msgs (ROS 2, 4.x): the detection list perception stacks consume.
OBJECT_HYPOTHESIS = msg("vision_msgs/msg/ObjectHypothesis", ("class_id", "string"),
                        ("score", "float64"))  # fmt: skip
HYPOTHESIS_WITH_POSE = msg("vision_msgs/msg/ObjectHypothesisWithPose",
                           ("hypothesis", OBJECT_HYPOTHESIS), ("pose", POSE_COV))  # fmt: skip
BOUNDING_BOX_3D = msg("vision_msgs/msg/BoundingBox3D", ("center", POSE), ("size", VECTOR3))
DETECTION_3D = msg("vision_msgs/msg/Detection3D", ("header", HEADER),
                   ("results", HYPOTHESIS_WITH_POSE, "sequence"), ("bbox", BOUNDING_BOX_3D),
                   ("id", "string"))  # fmt: skip
DETECTION_3D_ARRAY = msg("vision_msgs/msg/Detection3DArray", ("header", HEADER),
                         ("detections", DETECTION_3D, "sequence"))  # fmt: skip

# carlaverse_msgs: what no standard package carries (docs/protocol.md gives the .msg files).
TRAFFIC_LIGHT = msg("carlaverse_msgs/msg/TrafficLight", ("id", "string"), ("state", "string"),
                    ("phase", "int64"), ("remaining_s", "float64"))  # fmt: skip
TRAFFIC_LIGHT_ARRAY = msg("carlaverse_msgs/msg/TrafficLightArray", ("header", HEADER),
                          ("lights", TRAFFIC_LIGHT, "sequence"))  # fmt: skip
COLLISION_IMPULSE = msg(
    "carlaverse_msgs/msg/CollisionImpulse",
    ("header", HEADER), ("contact_id", "int64"), ("impulse", VECTOR3), ("point", POINT),
    ("normal", VECTOR3), ("other_id", "string"), ("other_kind", "string"),
    ("relative_speed_mps", "float64"),
)  # fmt: skip


# --------------------------------------------------------------------------- type hash


def _field_description(field: Field) -> dict[str, Any]:
    nested = field.nested
    type_id = _TYPE_IDS["nested" if nested is not None else field.type]  # type: ignore[index]
    if field.collection == "array":
        type_id += _ARRAY_SHIFT
    elif field.collection == "sequence":
        type_id += _SEQUENCE_SHIFT
    return {
        "name": field.name,
        "type": {
            "type_id": type_id,
            "capacity": field.size,
            "string_capacity": 0,
            "nested_type_name": nested.name if nested is not None else "",
        },
    }


def _description(definition: MsgDef) -> dict[str, Any]:
    return {
        "type_name": definition.name,
        "fields": [_field_description(f) for f in definition.fields],
    }


def referenced(definition: MsgDef) -> dict[str, MsgDef]:
    """Every message type `definition` refers to, directly or not, by name."""
    found: dict[str, MsgDef] = {}
    stack = [definition]
    while stack:
        for field in stack.pop().fields:
            nested = field.nested
            if nested is not None and nested.name not in found:
                found[nested.name] = nested
                stack.append(nested)
    return found


@cache
def type_hash(definition: MsgDef) -> str:
    """REP 2011's RIHS01 hash of the type: 'RIHS01_' and 64 hex digits."""
    refs = referenced(definition)
    description = {
        "type_description": _description(definition),
        "referenced_type_descriptions": [_description(refs[n]) for n in sorted(refs)],
    }
    text = json.dumps(description, ensure_ascii=True, separators=(", ", ": "), sort_keys=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def msg_text(definition: MsgDef) -> str:
    """The definition as a `.msg` file (fields only), nested types named `pkg/Name`."""
    lines = []
    for field in definition.fields:
        nested = field.nested
        name = nested.name.replace("/msg/", "/") if nested is not None else str(field.type)
        suffix = {"single": "", "sequence": "[]", "array": f"[{field.size}]"}[field.collection]
        lines.append(f"{name}{suffix} {field.name}")
    return "\n".join(lines) + "\n"
