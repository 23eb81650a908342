"""A ROS 2 node on a Zenoh session, as rmw_zenoh makes one: a liveliness token for the node,
one per publisher and subscription, samples on the data keys with their attachment.

    node = RosNode(session, "carlaverse_bridge", domain=0)
    tf = node.publisher("/tf", TF_MESSAGE)
    tf.publish({"transforms": [...]}, stamp_ns)
    node.subscription("/av/odom", ODOMETRY, on_odometry)   # on_odometry(dict, stamp_ns)
    node.close()

A subscription's callback runs on Zenoh's thread with the decoded message: it must not wait.
A payload that does not decode is counted in `dropped` by topic and never reaches it.
"""

from __future__ import annotations

import itertools
import logging
import os
from collections.abc import Callable
from typing import Any

import zenoh

from carlaverse.ros2 import cdr
from carlaverse.ros2 import keys as k
from carlaverse.ros2.types import MsgDef
from carlaverse.support.tally import Tally

log = logging.getLogger(__name__)

OnMessage = Callable[[dict[str, Any]], None]


class RosPublisher:
    def __init__(self, node: RosNode, topic: str, definition: MsgDef, eid: int) -> None:
        self.topic = k.check_topic(topic)
        self.definition = definition
        self.key = k.data_key(node.domain, topic, definition)
        self.gid = os.urandom(k.GID_SIZE)
        self.sent = 0
        self.closed = False
        self._publisher = node.session.declare_publisher(
            self.key, congestion_control=zenoh.CongestionControl.DROP
        )
        self._token = node.session.liveliness().declare_token(
            k.endpoint_token(node.domain, node.zid, node.nid, eid, "MP", node.namespace,
                             node.name, topic, definition)
        )  # fmt: skip

    def publish(self, value: dict[str, Any], source_time_ns: int) -> None:
        """Encode and send one message now (never blocks: a congested link drops it)."""
        payload = cdr.encode(self.definition, value)
        self.sent += 1
        self._publisher.put(payload, attachment=k.attachment(self.sent, source_time_ns, self.gid))

    def close(self) -> None:
        """Undeclare it and its graph token (again: nothing)."""
        if self.closed:
            return
        self.closed = True
        self._token.undeclare()
        self._publisher.undeclare()


class RosNode:
    def __init__(
        self, session: zenoh.Session, name: str, *, domain: int = 0, namespace: str = "/"
    ) -> None:
        self.session = session
        self.name = k.check_node_name(name)
        self.namespace = namespace if namespace == "/" else k.check_topic(namespace, "namespace")
        if not 0 <= domain <= 232:  # ROS 2's domain ids (ROS_DOMAIN_ID)
            raise ValueError(f"ROS domain id {domain} is not 0-232")
        self.domain = domain
        self.zid = str(session.info.zid())
        self.nid = 0
        self._eids = itertools.count(1)
        self.dropped = Tally()
        self._entities: list[Any] = []
        self._publishers: list[RosPublisher] = []
        self._token = session.liveliness().declare_token(
            k.node_token(domain, self.zid, self.nid, self.namespace, name)
        )

    def publisher(self, topic: str, definition: MsgDef) -> RosPublisher:
        publisher = RosPublisher(self, topic, definition, next(self._eids))
        # the ones closed already (an ego's odometry when it left) are not kept
        self._publishers = [p for p in self._publishers if not p.closed] + [publisher]
        return publisher

    def subscription(self, topic: str, definition: MsgDef, on_message: OnMessage) -> None:
        """Hear `topic` (any type hash: a Humble publisher sends none) with `on_message`."""
        k.check_topic(topic)
        key = k.data_key_any_hash(self.domain, topic, definition)

        def heard(sample: zenoh.Sample) -> None:
            try:
                message = cdr.decode(definition, sample.payload.to_bytes())
            except cdr.CdrError as exc:
                self.dropped.add(topic)
                log.debug("dropped a sample on %s: %s", topic, exc)
                return
            try:
                on_message(message)
            except Exception:  # a broken handler must not kill Zenoh's thread; say so
                self.dropped.add(f"{topic}/handler")
                log.exception("handler of %s failed", topic)

        self._entities.append(self.session.declare_subscriber(key, heard))
        token = k.endpoint_token(self.domain, self.zid, self.nid, next(self._eids), "MS",
                                 self.namespace, self.name, topic, definition)  # fmt: skip
        self._entities.append(self.session.liveliness().declare_token(token))

    def close(self) -> None:
        for publisher in self._publishers:
            publisher.close()
        for entity in self._entities:
            entity.undeclare()
        self._publishers.clear()
        self._entities.clear()
        self._token.undeclare()
