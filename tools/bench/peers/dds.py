"""CycloneDDS (the `cyclonedds` Python binding; ROS 2's default middleware) in its low-latency
configuration: BEST_EFFORT reliability, KEEP_LAST 1 history, volatile durability, no write
batching (the default), no shared-memory exchange (none is configured), loopback only with unicast
discovery (multicast off, peers 127.0.0.1).

The pose travels as a 64-byte octet array (`array<uint8, 64>`, which the binding copies as
one block) and is decoded by the same decoder as every other path.
"""

from __future__ import annotations

import os
from typing import Any

from carlaverse.messages import Pose, encode_pose
from peers.transport import Deliver, Plan, ReceiveThread, Transport

TOPIC = "bench_pose"
WAIT_MS = 200  # [ms] how long a wait may block before the thread checks for close
TAKE_AT_MOST = 32  # samples taken per wake-up
CONFIG = """<CycloneDDS><Domain id="any">
  <General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>
    <AllowMulticast>false</AllowMulticast></General>
  <Discovery><ParticipantIndex>auto</ParticipantIndex>
    <MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>
    <Peers><Peer address="127.0.0.1"/></Peers></Discovery>
</Domain></CycloneDDS>"""


def _pose_type() -> Any:
    from peers.dds_types import PoseBlob

    return PoseBlob


def _participant_and_topic(plan: Plan) -> tuple[Any, Any, Any]:
    """A participant of this run's domain, the pose topic, and the low-latency QoS."""
    os.environ["CYCLONEDDS_URI"] = CONFIG  # read when the first participant is created
    from cyclonedds.core import Policy, Qos
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.topic import Topic

    qos = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))
    participant = DomainParticipant(plan.options["dds_domain"])
    return participant, Topic(participant, TOPIC, _pose_type(), qos=qos), qos


class DdsSender:
    def __init__(self, plan: Plan) -> None:
        from cyclonedds.pub import DataWriter

        self._participant, topic, qos = _participant_and_topic(plan)
        self._writer = DataWriter(self._participant, topic, qos=qos)
        self._blob = _pose_type()

    def send(self, pose: Pose) -> None:
        self._writer.write(self._blob(encode_pose(pose)))

    def close(self) -> None:
        self._participant = self._writer = None  # the binding frees entities with them


class DdsReceiver(ReceiveThread):
    def __init__(self, plan: Plan, deliver: Deliver) -> None:
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
        from cyclonedds.sub import DataReader

        super().__init__("dds-rx")
        self._deliver = deliver
        self._participant, topic, qos = _participant_and_topic(plan)
        self._reader = DataReader(self._participant, topic, qos=qos)
        self._blob = _pose_type()
        mask = ViewState.Any | InstanceState.Any | SampleState.NotRead
        self._condition = ReadCondition(self._reader, mask)
        self._waitset = WaitSet(self._participant)
        self._waitset.attach(self._condition)

    def receive_once(self) -> None:
        from cyclonedds.util import duration

        self._waitset.wait(duration(milliseconds=WAIT_MS))
        for sample in self._reader.take(TAKE_AT_MOST, condition=self._condition):
            if isinstance(sample, self._blob):  # not an InvalidSample (a state change)
                self._deliver.payload(sample.data)

    def release(self) -> None:
        self._waitset = self._condition = self._reader = self._participant = None


class CycloneDds(Transport):
    label = "CycloneDDS"
    modules = ("cyclonedds",)

    def open_sender(self, plan: Plan) -> DdsSender:
        return DdsSender(plan)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> DdsReceiver:
        return DdsReceiver(plan, deliver).start()
