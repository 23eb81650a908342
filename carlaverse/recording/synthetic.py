"""A synthetic session: real messages on real keys, without SUMO or an authority process.

Benchmarks and tests of recording, replay and the viewer need traffic whose every sample is
known. `SyntheticSession` publishes it on a Zenoh session with the real codecs: egos driving
circles, an NPC batch on straight lanes, traffic lights cycling, weather, spawn events and
an occasional collision impulse; it also answers the authority queries a recorder or viewer
makes (`map`, `snapshot`, `configs`, `scenario`, `clock`). It counts what it published per
key, and can keep every payload, so a test can compare a recording with the truth.
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import zenoh

from carlaverse import messages as m
from carlaverse.keys import Keys, tile_of, tile_token

MAP_HALF_SIZE_M = 100.0  # [m] the synthetic map is a cross of two roads this long each way
LIGHT_CYCLE_S = 4.0  # [s] per phase
_LIGHT_PHASES = ("GGrr", "yyrr", "rrGG", "rryy")


@dataclass(frozen=True, slots=True)
class SyntheticSpec:
    egos: int = 2
    npcs: int = 8
    pose_hz: float = 50.0  # [Hz] ego pose rate
    npc_hz: float = 20.0  # [Hz] NPC batch rate
    slow_hz: float = 1.0  # [Hz] lights and weather refresh
    impulse_every_s: float = 2.0  # [s] between synthetic collisions (0: none)
    # Poses and NPC batches are droppable on the fabric (docs/architecture.md §4); tests
    # that count every sample make them reliable so a loaded machine cannot drop one in
    # Zenoh's queues.
    reliable_state: bool = False


def ego_id(i: int) -> str:
    return f"ego-{i}"


def npc_id(i: int) -> str:
    return f"npc-{i}"


def ego_pose(i: int, seq: int, t: float) -> m.Pose:
    """Ego i drives a circle of radius 20 + 5 i m at 10 m/s, centred on the junction.

    Its acceleration is the circle's, v^2 / r towards the centre: a pose that turns at its
    yaw rate and says it does not accelerate contradicts itself, and the motion model that
    projects it (`dead_reckoning.project`, present mode) would drive it straight on."""
    radius = 20.0 + 5.0 * i  # [m]
    omega = 10.0 / radius  # [rad/s]
    a = omega * t + i
    x, y = radius * math.cos(a), radius * math.sin(a)
    yaw = a + math.pi / 2
    vx, vy = -10.0 * math.sin(a), 10.0 * math.cos(a)
    ax, ay = -10.0 * omega * math.cos(a), -10.0 * omega * math.sin(a)  # [m/s²] v² / r inwards
    return m.Pose(seq, t, x, y, 0.0, 0.0, 0.0, yaw, vx, vy, 0.0, 0.0, 0.0, omega, ax, ay, 0.0)


def npc_rows(count: int, t: float) -> np.ndarray:
    """NPCs drive along the x road at 8 m/s, wrapping at the map edge."""
    rows = np.zeros(count, dtype=m.NPC_DTYPE)
    i = np.arange(count)
    rows["x"] = (i * 15.0 + 8.0 * t) % (2 * MAP_HALF_SIZE_M) - MAP_HALF_SIZE_M
    rows["y"] = np.where(i % 2 == 0, -1.75, 1.75)
    rows["vx"] = 8.0
    rows["length"], rows["width"], rows["height"] = 4.5, 1.8, 1.5
    rows["kind"] = i % 3  # car, van, truck
    return rows


def synthetic_map() -> m.MapReply:
    h = MAP_HALF_SIZE_M
    lanes = [
        m.MapLane("x_0", "road", 3.5, [(-h, -1.75), (-5.0, -1.75)]),
        m.MapLane("x_1", "road", 3.5, [(h, 1.75), (5.0, 1.75)]),
        m.MapLane("y_0", "road", 3.5, [(1.75, -h), (1.75, -5.0)]),
        m.MapLane("y_1", "road", 3.5, [(-1.75, h), (-1.75, 5.0)]),
        m.MapLane("c_0", "crossing", 3.0, [(-6.5, -5.0), (-6.5, 5.0)]),
    ]
    light = m.MapLight("J0", (0.0, 0.0), ["x_0", "x_1", "y_0", "y_1"])
    area = m.MapArea("J0", "junction", [(-5, -5), (5, -5), (5, 5), (-5, 5)])
    return m.MapReply(m.SCHEMA_VERSION, "synthetic-cross", (-h, -h, h, h), lanes, [area], [light])


def light_state(seq: int, t: float) -> m.LightsState:
    phase = int(t // LIGHT_CYCLE_S) % len(_LIGHT_PHASES)
    remaining = LIGHT_CYCLE_S - (t % LIGHT_CYCLE_S)
    return m.LightsState(seq, t, [m.TrafficLight("J0", _LIGHT_PHASES[phase], phase, remaining)])


class SyntheticSession:
    """Publishes a scripted world on `keys`; call `tick(t)` or `run()` from one thread."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: Keys,
        spec: SyntheticSpec = SyntheticSpec(),
        *,
        keep_payloads: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.session = session
        self.keys = keys
        self.spec = spec
        self.published: Counter[str] = Counter()
        self.queries: Counter[str] = Counter()  # authority queries answered, by name
        self.payloads: list[tuple[str, bytes]] | None = [] if keep_payloads else None
        self.configs = {
            ego_id(i): f"node_id: {ego_id(i)}\nkind: scripted\n# é\n" for i in range(spec.egos)
        }
        self.scenario_yaml = "name: synthetic-cross\nseed: 7\n"
        self._clock = clock
        self._t0 = clock()
        self._seq: Counter[str] = Counter()
        self._due: dict[str, float] = {}
        self._last_light_phase = -1
        self._queryables: list[zenoh.Queryable] = []
        self._publishers = self._declare_publishers()

    def now(self) -> float:
        """[s] session time."""
        return self._clock() - self._t0

    # ------------------------------------------------------------------ publishing

    def _declare_publishers(self) -> dict[str, zenoh.Publisher]:
        reliable: dict[str, Any] = dict(congestion_control=zenoh.CongestionControl.BLOCK)
        fast: dict[str, Any] = dict(congestion_control=zenoh.CongestionControl.DROP, express=True)
        if self.spec.reliable_state:
            fast = dict(reliable, express=True)
        self._fast = fast  # for pose keys of tiles the egos drive into later
        keys = {self._pose_key(i, 0.0): fast for i in range(self.spec.egos)}
        keys[self.keys.world("npc")] = fast
        for channel in ("lights", "weather", "events"):
            keys[self.keys.world(channel)] = reliable
        keys.update({self.keys.impulse(ego_id(i)): reliable for i in range(self.spec.egos)})
        return {key: self.session.declare_publisher(key, **qos) for key, qos in keys.items()}

    def all_matched(self) -> bool:
        """True once every stream has a subscriber (a recorder or viewer is listening)."""
        # zenoh 1.10's stub types `matching_status` as bool; it is a MatchingStatus at run time.
        return all(p.matching_status.matching for p in self._publishers.values())  # type: ignore[attr-defined]

    def _pose_key(self, i: int, t: float) -> str:
        """Ego i's pose key at time t: it ends in the tile the ego is in then."""
        pose = ego_pose(i, 0, t)
        return self.keys.pose(ego_id(i), tile_token(*tile_of(pose.x, pose.y)))

    def put(self, key: str, payload: bytes) -> None:
        publisher = self._publishers.get(key)
        if publisher is None:  # an ego drove into another tile
            publisher = self._publishers[key] = self.session.declare_publisher(key, **self._fast)
        publisher.put(payload)
        self.published[key] += 1
        if self.payloads is not None:
            self.payloads.append((key, payload))

    def _next_seq(self, key: str) -> int:
        self._seq[key] += 1
        return self._seq[key]

    def _is_due(self, name: str, t: float, hz: float) -> bool:
        if hz <= 0 or t < self._due.get(name, 0.0):
            return False
        self._due[name] = max(self._due.get(name, 0.0) + 1.0 / hz, t)
        return True

    def spawn_all(self, t: float) -> None:
        events = self.keys.world("events")
        for i in range(self.spec.egos):
            event = m.Spawned(self._next_seq(events), t, ego_id(i), "car")
            self.put(events, m.WORLD_EVENT.encode(event))

    def tick(self, t: float) -> None:
        """Publish every stream that is due at session time `t` [s]."""
        if self._is_due("pose", t, self.spec.pose_hz):
            for i in range(self.spec.egos):
                seq = self._next_seq(self.keys.ego(ego_id(i), "pose"))  # one scope per ego
                self.put(self._pose_key(i, t), m.POSE.encode(ego_pose(i, seq, t)))
        if self.spec.npcs and self._is_due("npc", t, self.spec.npc_hz):
            key = self.keys.world("npc")
            ids = [npc_id(i) for i in range(self.spec.npcs)]
            batch = m.NpcBatch.pack(self._next_seq(key), t, ids, npc_rows(self.spec.npcs, t))
            self.put(key, m.NPC_BATCH.encode(batch))
        self._tick_slow(t)

    def _tick_slow(self, t: float) -> None:
        phase = int(t // LIGHT_CYCLE_S)
        if self._is_due("slow", t, self.spec.slow_hz) or phase != self._last_light_phase:
            self._last_light_phase = phase
            lights = self.keys.world("lights")
            self.put(lights, m.LIGHTS.encode(light_state(self._next_seq(lights), t)))
            weather = self.keys.world("weather")
            rain = 0.5 + 0.5 * math.sin(t / 10.0)
            self.put(
                weather, m.WEATHER.encode(m.Weather(self._next_seq(weather), t, precipitation=rain))
            )
        every_s = self.spec.impulse_every_s
        if self.spec.egos and every_s > 0 and self._is_due("impulse", t, 1.0 / every_s):
            self._collide(t)

    def _collide(self, t: float) -> None:
        node = ego_id(0)
        pose = ego_pose(0, 0, t)
        key = self.keys.impulse(node)
        impulse = m.Impulse(
            self._next_seq(key), t, self._seq[key], (1500.0, 0.0, 0.0), (pose.x, pose.y, 0.5),
            (1.0, 0.0, 0.0), npc_id(0), "car", 4.0,
        )  # fmt: skip
        self.put(key, m.IMPULSE.encode(impulse))

    def run(
        self, stop: threading.Event, duration_s: float | None = None, step_s: float = 0.002
    ) -> None:
        """Tick in real time until `stop` is set or `duration_s` of session time passed."""
        start = self.now()
        self.spawn_all(start)
        while not stop.is_set():
            t = self.now()
            if duration_s is not None and t - start >= duration_s:
                return
            self.tick(t)
            stop.wait(step_s)

    # ------------------------------------------------------------------ authority queries

    def serve_queries(self) -> None:
        """Answer map, snapshot, configs, scenario and clock as the authority would."""
        handlers = {
            "map": lambda: m.MAP.encode(synthetic_map()),
            "snapshot": self._snapshot,
            "configs": lambda: m.CONFIGS.encode(
                m.ConfigsReply(m.SCHEMA_VERSION, dict(self.configs), self.scenario_yaml)
            ),
            "scenario": lambda: m.SCENARIO.encode(
                m.ScenarioReply(m.SCHEMA_VERSION, "synthetic-cross", self.scenario_yaml, 7)
            ),
            "clock": lambda: m.CLOCK_REPLY.encode(m.ClockReply(self.now(), False)),
        }
        for name, make in handlers.items():
            key = self.keys.authority(name)
            self._queryables.append(
                self.session.declare_queryable(key, self._answer(name, key, make), complete=True)
            )

    def _answer(
        self, name: str, key: str, make: Callable[[], bytes]
    ) -> Callable[[zenoh.Query], None]:
        def reply(query: zenoh.Query) -> None:
            self.queries[name] += 1
            query.reply(key, make())

        return reply

    def _snapshot(self) -> bytes:
        t = self.now()
        egos = [
            m.EgoInfo(
                ego_id(i),
                "scripted",
                "car",
                m.Extent(),
                1500.0,
                "lab",
                m.encode_pose(ego_pose(i, 0, t)),
            )
            for i in range(self.spec.egos)
        ]
        snap = m.Snapshot(m.SCHEMA_VERSION, t, egos, None, light_state(0, t), m.Weather(0, t))
        return m.SNAPSHOT.encode(snap)

    def close(self) -> None:
        for q in self._queryables:
            q.undeclare()
        for p in self._publishers.values():
            p.undeclare()
        self._queryables.clear()
        self._publishers.clear()
