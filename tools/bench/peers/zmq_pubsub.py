"""ZeroMQ PUB/SUB over loopback TCP (pyzmq): the publisher binds, every receiver connects.

ZeroMQ sets TCP_NODELAY itself and sends each message as its own frame; nothing is tuned.
"""

from __future__ import annotations

from typing import Any

from carlaverse.messages import Pose, encode_pose
from peers.transport import Deliver, Plan, ReceiveThread, Transport

RECEIVE_TIMEOUT_MS = 200  # [ms] how long a receive may block before the thread checks for close


def _endpoint(plan: Plan) -> str:
    return f"tcp://127.0.0.1:{plan.ports[plan.receivers]}"


class ZmqSender:
    def __init__(self, plan: Plan) -> None:
        import zmq

        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.PUB)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.bind(_endpoint(plan))

    def send(self, pose: Pose) -> None:
        self._socket.send(encode_pose(pose), copy=True)

    def close(self) -> None:
        self._socket.close()
        self._context.term()


class ZmqReceiver(ReceiveThread):
    def __init__(self, plan: Plan, deliver: Deliver) -> None:
        import zmq

        super().__init__("zmq-rx")
        self._deliver = deliver
        self._context = zmq.Context()
        self._socket: Any = self._context.socket(zmq.SUB)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.setsockopt(zmq.RCVTIMEO, RECEIVE_TIMEOUT_MS)
        self._socket.setsockopt(zmq.SUBSCRIBE, b"")
        self._socket.connect(_endpoint(plan))
        self._again = zmq.Again

    def receive_once(self) -> None:
        try:
            payload = self._socket.recv(copy=True)
        except self._again:
            return
        self._deliver.payload(payload)

    def release(self) -> None:
        self._socket.close()
        self._context.term()


class ZmqPubSub(Transport):
    label = "ZeroMQ"
    modules = ("zmq",)

    def open_sender(self, plan: Plan) -> ZmqSender:
        return ZmqSender(plan)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> ZmqReceiver:
        return ZmqReceiver(plan, deliver).start()
