"""A CARLAverse node in plain `zenoh` + `msgpack`, written from docs/protocol.md alone.

    pip install 'eclipse-zenoh>=1.10,<1.11' msgpack
    python thirdparty_client.py --connect tcp/127.0.0.1:7447 --session lab --id partner-1

Joins, syncs its clock, holds its liveliness token, rides a 20 m circle at 50 Hz and prints a
JSON line a second of what it decoded (poses, NPCs, lights, weather, events, the snapshot).
"""

import argparse
import json
import math
import signal
import struct
import threading
import time
import uuid
from collections import Counter, deque

import msgpack
import zenoh

SCHEMA_VERSION = 3  # docs/protocol.md, "Versions and compatibility"
POSE = struct.Struct("<BBHId3f3f3f3e3e")  # the 64-byte pose
NPC_ROW = struct.Struct("<10fBBH")  # 44 bytes: x y z yaw vx vy yaw_rate l w h, kind, 0, lights
RATE_HZ = 50.0  # [Hz] pose rate
TILE_M = 250.0  # [m] map tiles: a pose's key ends in the tile it is in, t<ix>_<iy>


def circle_pose(seq: int, t: float) -> bytes:
    """Our bicycle at session time t: a 20 m circle at 6 m/s, counter-clockwise."""
    r, w = 20.0, 0.3  # radius [m], turn rate [rad/s]
    c, s, yaw = math.cos(w * t), math.sin(w * t), w * t + math.pi / 2
    return POSE.pack(1, 0, 0, seq & 0xFFFFFFFF, t, r * c, r * s, 0, 0, 0, yaw,
                     -r * w * s, r * w * c, 0, 0, 0, w, 0, 0, 0)  # fmt: skip


class Client:
    def __init__(self, args: argparse.Namespace) -> None:
        config = zenoh.Config()  # lease 2 s (Zenoh's default: 10 s): dropped 2 s after we freeze
        for path, value in {"mode": "client", "connect/endpoints": [args.connect],
                            "scouting/multicast/enabled": False, "transport/link/tx/lease": 2000,
                            "transport/link/tx/keep_alive": 4}.items():  # fmt: skip
            config.insert_json5(path, json.dumps(value))
        self.z = zenoh.open(config)
        self.prefix, self.id = f"carlaverse/{args.session}", args.id
        self.instance = uuid.uuid4().hex  # one per process: a re-join is not a duplicate
        self.offset = time.time() - time.monotonic()  # session − local [s], until measured
        self.exchanges: list[tuple[float, float]] = []  # (rtt, offset) of the last 16
        self.joined, self.left, self.token = threading.Event(), threading.Event(), None
        self.authority = ""  # zid of the authority's session: world messages must carry it
        self.egos: dict[str, list[float]] = {}  # id -> last [x, y]
        self.world: dict[str, object] = {"npcs": 0}  # newest lights, weather, NPC count
        self.count, self.events = Counter(), deque(maxlen=10)  # tallies, last 10 world events
        p = self.prefix
        self.z.declare_subscriber(f"{p}/ego/*/pose/**", self.guarded(self.on_pose))  # all tiles
        presence = self.guarded(self.on_presence)
        self.z.liveliness().declare_subscriber(f"{p}/node/*", presence, history=True)

    def query(self, name: str, request: dict | None) -> bytes | None:
        payload = msgpack.packb(request) if request is not None else b""
        for reply in self.z.get(f"{self.prefix}/authority/{name}", payload=payload, timeout=2.0):
            if reply.ok is not None:
                return reply.ok.payload.to_bytes()
            print(f"authority/{name} error: {reply.err.payload.to_string()}", flush=True)
        return None

    def join(self) -> None:
        raw = self.query("join", {
            "schema": SCHEMA_VERSION, "node_id": self.id, "instance": self.instance,
            "kind": "thirdparty", "actor_kind": "bicycle", "extent": [1.8, 0.6, 1.7],
            "mass_kg": 90.0, "site": "partner-lab", "pose_rate_hz": RATE_HZ,
        })  # fmt: skip
        if raw is None:
            return
        reply = msgpack.unpackb(raw)
        if not reply["accepted"]:
            raise SystemExit(f"join refused: {reply['reason']}")
        self.authority = reply["authority_instance"]
        if self.token is None:  # presence: without it nobody accepts our poses
            self.token = self.z.liveliness().declare_token(f"{self.prefix}/node/{self.id}")
            self.z.declare_subscriber(f"{self.prefix}/world/*", self.guarded(self.on_world))
        self.joined.set()
        snapshot = msgpack.unpackb(self.query("snapshot", None) or msgpack.packb({"egos": []}))
        for ego in snapshot["egos"]:  # "pose": the 64-byte layout, or nil (observers)
            if ego["pose"] and ego["node_id"] != self.id:
                x, y = POSE.unpack(ego["pose"])[5:7]
                self.egos.setdefault(ego["node_id"], [round(x, 2), round(y, 2)])

    def sync_clock(self) -> None:
        t0 = time.monotonic()
        raw = self.query("clock", {"node_id": self.id})
        t1 = time.monotonic()
        if raw is None:
            return
        ts, known = msgpack.unpackb(raw)  # an array: [session time, am I joined]
        self.exchanges = [*self.exchanges[-15:], (t1 - t0, ts - (t0 + t1) / 2)]
        self.offset = min(self.exchanges)[1]  # the lowest round trip bounds the error best
        if not known:
            self.joined.clear()  # the authority lost us (restart, despawn): join again

    def guarded(self, handler):  # a bad message is counted, never raised into Zenoh's thread
        def run(sample: zenoh.Sample) -> None:
            try:
                handler(sample)
            except (ValueError, TypeError, KeyError, IndexError, struct.error):
                self.count[f"dropped_{handler.__name__}"] += 1

        return run

    def on_pose(self, sample: zenoh.Sample) -> None:
        node_id, raw = str(sample.key_expr).split("/")[3], sample.payload.to_bytes()
        if node_id == self.id or len(raw) != POSE.size or raw[0] != 1:
            return
        values = POSE.unpack(raw)[4:]  # t, x, y, z, roll, pitch, yaw, v, w, a
        if not all(map(math.isfinite, values)):
            raise ValueError("non-finite pose")
        self.egos[node_id] = [round(values[1], 2), round(values[2], 2)]
        self.count["poses"] += 1

    def on_world(self, sample: zenoh.Sample) -> None:
        """npc, lights, weather, events: only if the authority's own session stamped them."""
        stamp, channel = sample.timestamp, str(sample.key_expr).rsplit("/", 1)[1]
        if stamp is None or str(stamp.get_id()) != self.authority:
            raise ValueError("not from the joined authority")
        message = msgpack.unpackb(sample.payload.to_bytes())
        if channel == "npc":
            _seq, _t, ids, rows = message  # an array
            if len(rows) != len(ids) * NPC_ROW.size:
                raise ValueError("NPC rows do not match the ids")
            self.world["npcs"] = sum(1 for _row in NPC_ROW.iter_unpack(rows))
        elif channel == "events":
            self.on_event(message)
        else:
            self.world[channel] = message  # lights, weather: maps, on change and at 1 Hz
        self.count[channel] += 1

    def on_event(self, event: dict) -> None:  # a map tagged by "type"
        who = event.get("node_id") or f"{event['a']}+{event['b']}"
        self.events.append(f"{event['type']}:{who}:{event.get('reason', '')}".rstrip(":"))
        if event["type"] == "despawned":
            self.egos.pop(event["node_id"], None)
            if event["node_id"] == self.id and event["reason"] == "left":
                self.left.set()  # our leave is announced: the token may go
            elif event["node_id"] == self.id:
                self.joined.clear()  # the authority dropped us: join again

    def on_presence(self, sample: zenoh.Sample) -> None:
        node_id = str(sample.key_expr).rsplit("/", 1)[1]
        if node_id == "authority":
            self.joined.clear()  # a new (or no) authority knows nothing of us
        elif sample.kind == zenoh.SampleKind.DELETE:
            self.egos.pop(node_id, None)

    def publish(self, stop: threading.Event) -> None:
        seq, next_t, pubs = 0, time.monotonic(), {}  # a publisher per tile we drive through
        while not stop.is_set():
            if self.token is not None:  # only once joined
                seq += 1
                pose = circle_pose(seq, time.monotonic() + self.offset)  # session time
                x, y = POSE.unpack(pose)[5:7]
                tile = f"t{math.floor(x / TILE_M)}_{math.floor(y / TILE_M)}"
                if tile not in pubs:  # best effort: a late pose is a useless pose
                    key = f"{self.prefix}/ego/{self.id}/pose/{tile}"
                    pubs[tile] = self.z.declare_publisher(
                        key, congestion_control=zenoh.CongestionControl.DROP
                    )
                pubs[tile].put(pose)
            next_t += 1 / RATE_HZ
            stop.wait(max(0.0, next_t - time.monotonic()))

    def status(self) -> str:
        lights, weather = self.world.get("lights") or {}, self.world.get("weather") or {}
        return json.dumps({"id": self.id, "joined": self.joined.is_set(), "egos": dict(self.egos),
                           "npcs": self.world["npcs"], "lights": len(lights.get("lights", [])),
                           "cloudiness": weather.get("cloudiness"), "events": list(self.events),
                           "counts": dict(self.count)})  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", default="tcp/127.0.0.1:7447", help="site router endpoint")
    parser.add_argument("--session", default="default")
    parser.add_argument("--id", default="partner-1", help="node id, unique in the session")
    args = parser.parse_args()
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    client = Client(args)
    (publisher := threading.Thread(target=client.publish, args=(stop,))).start()
    while not stop.wait(1.0 if client.joined.is_set() else 0.5):
        if not client.joined.is_set():
            client.join()  # (again, after an authority restart or a despawn)
        for _ in range(8 if len(client.exchanges) < 8 else 1):
            client.sync_clock()  # a burst at first, then one a second
        print(client.status(), flush=True)
    publisher.join()
    if client.token is not None:  # leave on purpose (reason `left`), then drop presence
        client.query("leave", {"node_id": client.id, "instance": client.instance})
        client.left.wait(0.5)  # so peers hear `left` before the token's DELETE
        client.token.undeclare()
    client.z.close()


if __name__ == "__main__":
    main()
