"""The compared transports by name -> (module, class), imported only when used."""

from __future__ import annotations

import importlib

from peers.transport import Transport

TRANSPORTS = {
    "pose": ("peers.pose_path", "PosePath"),
    "pose-ll": ("peers.pose_path", "PosePathLowLatency"),
    "zenoh": ("peers.zenoh_bare", "BareZenoh"),
    "zenoh-loop": ("peers.zenoh_bare", "BareZenohNodeLoop"),
    "zenoh-direct": ("peers.zenoh_bare", "BareZenohDirect"),
    "zenoh-ll": ("peers.zenoh_bare", "BareZenohLowLatency"),
    "zenoh-fast": ("peers.zenoh_bare", "BareZenohFastest"),
    "zenoh-pose-options": ("peers.zenoh_bare", "BareZenohPoseOptions"),
    "zenoh-express": ("peers.zenoh_bare", "BareZenohExpress"),
    "pose-no-loop": ("peers.pose_path", "PosePathNoNodeLoop"),
    "pose-no-routes": ("peers.pose_path", "PosePathNoRoutes"),
    "dds": ("peers.dds", "CycloneDds"),
    "zmq": ("peers.zmq_pubsub", "ZmqPubSub"),
    "mqtt": ("peers.mqtt", "Mqtt"),
    "udp": ("peers.udp", "Udp"),
}
# The comparison the issue asks for, and variants that take the pose path apart (--diagnose).
COMPARED = (
    "pose",
    "pose-ll",
    "zenoh",
    "zenoh-loop",
    "zenoh-ll",
    "zenoh-fast",
    "dds",
    "zmq",
    "mqtt",
    "udp",
)
DIAGNOSTIC = (
    "pose",
    "zenoh",
    "zenoh-loop",
    "zenoh-direct",
    "zenoh-pose-options",
    "pose-no-loop",
    "pose-no-routes",
)
REFERENCE = "pose"  # the path every other one is compared with
LOW_LATENCY = "pose-ll"  # the same path in the fabric's low-latency configuration


def load(name: str) -> Transport:
    """The transport called `name`; ValueError naming the known ones otherwise."""
    if name not in TRANSPORTS:
        raise ValueError(f"unknown transport {name!r}: choose from {', '.join(TRANSPORTS)}")
    module, cls = TRANSPORTS[name]
    return getattr(importlib.import_module(module), cls)()
