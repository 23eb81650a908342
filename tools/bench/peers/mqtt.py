"""MQTT through a local mosquitto broker (paho-mqtt clients, QoS 0).

Low-latency settings on both sides: the broker sets TCP_NODELAY on its client sockets
(`set_tcp_nodelay true`, off by default) and so does each client here (paho leaves Nagle on),
persistence is off. Each pose crosses loopback twice (publisher -> broker -> receiver).
"""

from __future__ import annotations

import socket
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from carlaverse.messages import Pose, encode_pose
from peers.transport import Deliver, NoPoll, Plan, Transport, find_program, wait_for_port

TOPIC = "bench/pose"
KEEPALIVE_S = 60  # [s] MQTT keep-alive: longer than a run, so no pings in the window


def _broker_port(plan: Plan) -> int:
    return plan.ports[plan.receivers]


class Mosquitto:
    """A private mosquitto on 127.0.0.1 for one run."""

    name = "mosquitto"

    def __init__(self, port: int) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="bench-mqtt-")
        conf = Path(self._dir.name) / "mosquitto.conf"
        conf.write_text(
            f"listener {port} 127.0.0.1\nallow_anonymous true\nset_tcp_nodelay true\n"
            "persistence false\nlog_dest none\n"
        )
        self._port = port
        broker = find_program("mosquitto") or "mosquitto"
        self._proc = subprocess.Popen([broker, "-c", str(conf)], stdin=subprocess.DEVNULL)
        self.pid = self._proc.pid

    def wait_ready(self, timeout_s: float) -> bool:
        return wait_for_port(self._port, timeout_s) and self._proc.poll() is None

    def stop(self) -> None:
        self._proc.terminate()
        self._proc.wait(timeout=10)
        self._dir.cleanup()


def _client(plan: Plan, name: str) -> Any:
    import paho.mqtt.client as paho

    client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id=name)
    client.connect("127.0.0.1", _broker_port(plan), keepalive=KEEPALIVE_S)
    client.socket().setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return client


class MqttSender:
    def __init__(self, plan: Plan) -> None:
        self._client = _client(plan, "bench-tx")
        self._client.loop_start()

    def send(self, pose: Pose) -> None:
        self._client.publish(TOPIC, encode_pose(pose), qos=0)

    def close(self) -> None:
        self._client.loop_stop()
        self._client.disconnect()


class MqttReceiver(NoPoll):
    def __init__(self, plan: Plan, index: int, deliver: Deliver) -> None:
        self._client = _client(plan, f"bench-rx{index}")
        self._client.on_message = lambda _client, _userdata, msg: deliver.payload(msg.payload)
        self._client.subscribe(TOPIC, qos=0)
        self._client.loop_start()

    def close(self) -> None:
        self._client.loop_stop()
        self._client.disconnect()


class Mqtt(Transport):
    label = "MQTT (mosquitto)"
    modules = ("paho.mqtt",)
    programs = ("mosquitto",)

    def infrastructure(self, plan: Plan) -> list[Mosquitto]:
        return [Mosquitto(_broker_port(plan))]

    def open_sender(self, plan: Plan) -> MqttSender:
        return MqttSender(plan)

    def open_receiver(self, plan: Plan, index: int, deliver: Deliver) -> MqttReceiver:
        return MqttReceiver(plan, index, deliver)
