"""Audio scenes from a real authority running SUMO, heard by nodes in this process over Zenoh.

The authority (its own process) runs the crossing with a dozen NPCs, an ambulance whose siren
the scenario declares, and rain that comes and goes every 4 s. Three listeners stand still
off the road, so SUMO does not carry them: `near` 18 m beside the west arm, `mid` 10 km away,
`far` 300 km away. With a 20 dB threshold (level at 1 m − 20·log10 distance):

- the siren (118 dB at 1 m) reaches 10 km at 38 dB but not 300 km (8.5 dB);
- no engine or tyres (≤ 96 dB at 1 m) reach 10 km (≤ 16 dB);
- every car or van engine, idling at least (68 dB at 1 m), is heard within 250 m, so when
  more than `max_emitters` NPCs are within 250 m of `near` the cap is what limits its scene.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from tests.support import Cluster, wait_until
from tests.traffic.helpers import CROSSING_MAP, write_scenario

K = Keys("t")
CAP = 6
SCENARIO = (
    CROSSING_MAP
    + f"""
traffic:
  vehicles: {{count: 12, mix: {{car: 0.8, van: 0.2}}}}
  pedestrians: {{count: 0}}
  scripted_vehicles:
    - {{id: ambulance, kind: van, edges: [WZ, ZC, CE], stop: {{edge: CE, pos_m: 60}}}}
weather:
  timeline:
    - {{at_s: 3.9, precipitation: 0.0}}
    - {{at_s: 4.0, precipitation: 0.8}}
    - {{at_s: 7.9, precipitation: 0.8}}
  loop_s: 8
audio:
  max_emitters: {CAP}
  threshold_db: 20
  sirens: [{{vehicle: ambulance, pattern: yelp}}]
"""
)
# Map frame: the junction C is at (160, 120); the west arm runs along y = 120 from x = 0.
PLACES = {"near": (50.0, 138.0), "mid": (160.0, 10_120.0), "far": (160.0, 300_120.0)}
IDLE_REACH_M = 250.0  # [m] an idling car engine (68 dB at 1 m) stays above 20 dB this far


@dataclass
class Heard:
    """Everything received, each list appended from Zenoh callbacks."""

    scenes: dict[str, list[m.AudioScene]] = field(default_factory=dict)
    weathers: list[m.Weather] = field(default_factory=list)
    npcs: list[m.NpcBatch] = field(default_factory=list)

    def weather_at(self, t: float) -> m.Weather | None:
        """The weather in effect at session time t: the last one sent at or before it."""
        before = [w for w in self.weathers if w.t <= t]
        return max(before, key=lambda w: w.t) if before else None

    def npcs_at(self, t: float) -> m.NpcBatch:
        return min(self.npcs, key=lambda b: abs(b.t - t))


def listener(cluster: Cluster, node_id: str, heard: Heard) -> NodeClient:
    """A car standing at its place, subscribed to its own `audio/<id>` only."""
    session = open_session(
        FabricSettings(connect=[cluster.endpoint]), deadline=time.monotonic() + 20
    )
    cluster.sessions.append(session)
    scenes: list[m.AudioScene] = heard.scenes.setdefault(node_id, [])
    session.declare_subscriber(
        K.audio(node_id), lambda s: scenes.append(m.AUDIO_SCENE.decode(s.payload.to_bytes()))
    )
    settings = NodeSettings(node_id=node_id, session="t", kind="drive", pose_rate_hz=20.0)
    client = NodeClient(session, settings, MonotonicClock())
    x, y = PLACES[node_id]
    client.start(lambda t: m.Pose(0, t, x, y))
    cluster.sessions.append(client)
    return client


def watch_world(cluster: Cluster, heard: Heard) -> None:
    session = open_session(
        FabricSettings(connect=[cluster.endpoint]), deadline=time.monotonic() + 20
    )
    cluster.sessions.append(session)
    for key, codec, into in ((K.world("weather"), m.WEATHER, heard.weathers),
                             (K.world("npc"), m.NPC_BATCH, heard.npcs)):  # fmt: skip
        session.declare_subscriber(
            key, lambda s, c=codec, i=into: i.append(c.decode(s.payload.to_bytes()))
        )


@pytest.fixture(scope="module")
def heard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Heard]:
    tmp = Path(tmp_path_factory.mktemp("audio"))
    cluster = Cluster(tmp)
    try:
        cluster.router()
        scenario = str(write_scenario(tmp, SCENARIO, "audio"))
        cluster.start("authority", "--scenario", scenario, "--session", "t",
                      "--connect", cluster.endpoint, name="authority")  # fmt: skip
        result = Heard()
        watch_world(cluster, result)
        wait_until(lambda: result.npcs, 60, "the authority's first NPC batch", poll=0.1)
        for node_id in PLACES:
            assert listener(cluster, node_id, result).wait_joined(20), node_id
        yield result
    finally:
        cluster.close()


def emitter_ids(scene: m.AudioScene) -> set[str]:
    return {e.id for e in scene.emitters}


def test_a_node_beside_the_road_hears_a_passing_npcs_engine_and_tyres(heard: Heard) -> None:
    def passing() -> str | None:
        for scene in list(heard.scenes["near"]):
            batch = heard.npcs_at(scene.t)
            rows = batch.array()
            for npc_id, row in zip(batch.ids, rows, strict=True):
                close = math.dist((row["x"], row["y"]), PLACES["near"]) < 30.0
                moving = math.hypot(row["vx"], row["vy"]) > 3.0
                both = {f"{npc_id}.engine", f"{npc_id}.tyres"} <= emitter_ids(scene)
                if close and moving and both:
                    return npc_id
        return None

    wait_until(passing, 40, "near to hear a passing NPC's engine and tyres", poll=0.2)


def test_the_cap_holds_when_more_npcs_are_in_earshot(heard: Heard) -> None:
    def capped_scene() -> m.AudioScene | None:
        for scene in list(heard.scenes["near"]):
            rows = heard.npcs_at(scene.t).array()
            in_earshot = sum(
                math.dist((r["x"], r["y"]), PLACES["near"]) < IDLE_REACH_M for r in rows
            )
            if in_earshot > CAP:
                return scene
        return None

    scene = wait_until(capped_scene, 40, f"more than {CAP} NPCs within earshot of near", poll=0.2)
    assert len(scene.emitters) == CAP
    assert all(len(s.emitters) <= CAP for s in heard.scenes["near"])


def test_the_siren_is_heard_at_ten_kilometres_and_not_at_three_hundred(heard: Heard) -> None:
    wait_until(lambda: any("ambulance.siren" in emitter_ids(s) for s in heard.scenes["mid"]), 40,
               "mid to hear the ambulance's siren", poll=0.2)  # fmt: skip
    siren = next(e for s in heard.scenes["mid"] for e in s.emitters if e.id == "ambulance.siren")
    assert siren.kind == "siren" and siren.drive_a == m.SIREN_PATTERNS.index("yelp")
    for node_id, allowed in (("mid", {"siren", "rain"}), ("far", {"rain"})):
        kinds = {e.kind for s in heard.scenes[node_id] for e in s.emitters}
        assert kinds <= allowed, node_id


def test_rain_emitters_follow_the_weather(heard: Heard) -> None:
    def rain(scene: m.AudioScene) -> m.AudioEmitter | None:
        return next((e for e in scene.emitters if e.kind == "rain"), None)

    def both_seen() -> bool:
        scenes = list(heard.scenes["far"])
        return any(rain(s) for s in scenes) and any(not rain(s) for s in scenes[1:])

    wait_until(both_seen, 30, "far to hear rain start or stop", poll=0.2)
    checked = 0
    for scene in list(heard.scenes["far"]):
        weather = heard.weather_at(scene.t)
        if weather is None:
            continue
        emitter = rain(scene)
        if weather.precipitation >= 0.02:
            assert emitter is not None and emitter.drive_a == weather.precipitation, scene.t
            assert (emitter.x, emitter.y) == pytest.approx(PLACES["far"])  # around the listener
        else:
            assert emitter is None, scene.t
        checked += 1
    assert checked > 20
