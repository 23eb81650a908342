"""Raw UDP: the publisher sends each pose to every receiver's own port (unicast, loopback)."""

from __future__ import annotations

import socket

from carlaverse.messages import Pose, encode_pose
from peers.transport import Deliver, Plan, ReceiveThread, Transport

RECEIVE_TIMEOUT_S = 0.2  # [s] how long a receive may block before the thread checks for close


class UdpSender:
    def __init__(self, plan: Plan) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._targets = [("127.0.0.1", port) for port in plan.ports[: plan.receivers]]

    def send(self, pose: Pose) -> None:
        payload = encode_pose(pose)
        for target in self._targets:
            self._sock.sendto(payload, target)

    def close(self) -> None:
        self._sock.close()


class UdpReceiver(ReceiveThread):
    def __init__(self, port: int, deliver: Deliver) -> None:
        super().__init__("udp-rx")
        self._deliver = deliver
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind(("127.0.0.1", port))
        self._sock.settimeout(RECEIVE_TIMEOUT_S)

    def receive_once(self) -> None:
        try:
            payload = self._sock.recv(2048)
        except TimeoutError:
            return
        self._deliver.payload(payload)

    def release(self) -> None:
        self._sock.close()


class Udp(Transport):
    label = "raw UDP"

    def open_sender(self, plan: Plan) -> UdpSender:
        return UdpSender(plan)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> UdpReceiver:
        return UdpReceiver(plan.ports[index], deliver).start()
