"""rmw_zenoh's key space: where a topic's samples travel, the liveliness tokens that make a
node and its publishers and subscriptions visible to `ros2 topic list`, and the attachment
each sample carries (rmw_zenoh docs/design.md, "Topic and Service name mapping to Zenoh key
expressions", "Graph Cache", "Publishers"):

    data        <domain>/<topic without its leading />/<dds type>/<type hash>
                0/tf/tf2_msgs::msg::dds_::TFMessage_/RIHS01_e369d0f0...
    node        @ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/<enclave>/<namespace>/<node>
    publisher   @ros2_lv/<domain>/<zid>/<nid>/<eid>/MP/<enclave>/<namespace>/<node>/<topic>/
                    <dds type>/<type hash>/<qos>          (a subscription: MS)

In a token a name's `/` is written `%` (a chunk of its own otherwise), and an empty enclave or
the root namespace is `%`. The attachment is three values in Zenoh's serialisation: sequence
number (int64), source timestamp [ns] (int64) and the publisher's 16-byte gid (a LEB128 length,
16, then the bytes).
"""

from __future__ import annotations

import re
import struct

from carlaverse.ros2.types import MsgDef, dds_name, type_hash

LIVELINESS_ROOT = "@ros2_lv"
# rmw_zenoh's QoS in a token, defaults left empty: reliable, volatile, keep last 10, no
# deadline or lifespan, automatic liveliness -- ROS 2's default profile.
DEFAULT_QOS = "::,10:,:,:,,"
GID_SIZE = 16  # [bytes]
_ATTACHMENT_HEAD = struct.Struct("<qq")

# A fully qualified ROS 2 name: `/` and tokens of letters, digits and `_`, not starting with a
# digit (rcl's rules; `~` and substitutions are resolved before a name reaches the wire).
_NAME = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
_NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class RosNameError(ValueError):
    """A topic, namespace or node name ROS 2 would refuse."""


def check_topic(topic: str, what: str = "topic") -> str:
    """`topic` when it is a fully qualified ROS 2 name ('/carlaverse/odom'); else RosNameError."""
    if not _NAME.fullmatch(topic):
        raise RosNameError(
            f"{what} {topic!r} is not a fully qualified ROS 2 name: '/' then tokens of "
            "letters, digits and '_' that do not start with a digit, e.g. /av/odom"
        )
    return topic


def check_node_name(name: str) -> str:
    if not _NODE_NAME.fullmatch(name):
        raise RosNameError(
            f"node name {name!r}: letters, digits and '_', not starting with a digit"
        )
    return name


def ros_token(text: str) -> str:
    """`text` (a node id: letters, digits, `-`, `_`, `.`) as a ROS 2 name token."""
    token = re.sub(r"[^A-Za-z0-9_]", "_", text)
    return token if token and not token[0].isdigit() else f"_{token}"


def mangle(name: str) -> str:
    """A name as one token chunk: every `/` written `%`; empty is `%`."""
    return name.replace("/", "%") if name else "%"


def data_key(domain: int, topic: str, definition: MsgDef) -> str:
    return f"{domain}/{topic.lstrip('/')}/{dds_name(definition)}/{type_hash(definition)}"


def data_key_any_hash(domain: int, topic: str, definition: MsgDef) -> str:
    """The data key with the hash chunk a wildcard: a Humble publisher writes
    `TypeHashNotSupported` there, and the bytes are the same."""
    return f"{domain}/{topic.lstrip('/')}/{dds_name(definition)}/*"


def node_token(domain: int, zid: str, nid: int, namespace: str, node: str) -> str:
    ns = "%" if namespace in ("", "/") else mangle(namespace)
    return f"{LIVELINESS_ROOT}/{domain}/{zid}/{nid}/{nid}/NN/%/{ns}/{node}"


def endpoint_token(
    domain: int,
    zid: str,
    nid: int,
    eid: int,
    kind: str,
    namespace: str,
    node: str,
    topic: str,
    definition: MsgDef,
    qos: str = DEFAULT_QOS,
) -> str:
    """A publisher's (`MP`) or subscription's (`MS`) token."""
    ns = "%" if namespace in ("", "/") else mangle(namespace)
    return (
        f"{LIVELINESS_ROOT}/{domain}/{zid}/{nid}/{eid}/{kind}/%/{ns}/{node}/{mangle(topic)}/"
        f"{dds_name(definition)}/{type_hash(definition)}/{qos}"
    )


def attachment(seq: int, source_time_ns: int, gid: bytes) -> bytes:
    if len(gid) != GID_SIZE:
        raise ValueError(f"a gid is {GID_SIZE} bytes, got {len(gid)}")
    return _ATTACHMENT_HEAD.pack(seq, source_time_ns) + bytes([GID_SIZE]) + gid


def read_attachment(raw: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp [ns], gid); ValueError when malformed."""
    if len(raw) < _ATTACHMENT_HEAD.size + 1:
        raise ValueError(f"attachment of {len(raw)} bytes is too short")
    seq, stamp = _ATTACHMENT_HEAD.unpack_from(raw)
    size = raw[_ATTACHMENT_HEAD.size]
    gid = raw[_ATTACHMENT_HEAD.size + 1 :]
    if size != len(gid):
        raise ValueError(f"attachment announces a {size}-byte gid, carries {len(gid)}")
    return seq, stamp, gid
