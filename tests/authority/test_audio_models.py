"""Sound models and audibility, worked by hand: engines, tyres, areas, weather, the cap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse.authority.actors import EgoNow
from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.authority.sound_areas import ListenerAreas, MapAreaSources
from carlaverse.authority.sound_audibility import audible
from carlaverse.authority.sound_models import EngineBank, TyreBank
from carlaverse.authority.sound_publisher import SoundPublisher
from carlaverse.authority.sound_sources import KIND_INDEX, ActorSounds, SoundSources, actor_columns
from carlaverse.messages import AUDIO_SCENE, NPC_DTYPE, MapArea, Weather
from carlaverse.traffic.engine import NpcFrame, kind_code
from carlaverse.traffic.soundscape import AudioSpec, ConstructionZone, SirenSpec

CAR, TRUCK, BICYCLE = kind_code("car"), kind_code("truck"), kind_code("bicycle")


def codes(*kinds: int) -> np.ndarray:
    return np.array(kinds, dtype=np.intp)


def test_a_standing_car_idles_and_a_cruising_car_is_in_second_gear() -> None:
    engine = EngineBank().run(codes(CAR, CAR), np.array([0.0, 10.0]), np.array([0.0, 0.0]))
    assert engine.rpm.tolist() == pytest.approx([800.0, 2500.0])  # 10 m/s in 2nd: 3000·10/12
    cruise = 0.1 + 0.5 * (10 / 45) ** 2  # rolling and air drag share of full load
    assert engine.load.tolist() == pytest.approx([0.0, cruise])
    idle_db, rpm_db = 68.0, 30.0 * math.log10(2500 / 800)
    assert engine.level_db.tolist() == pytest.approx([idle_db, idle_db + rpm_db + 8.0 * cruise])


def test_acceleration_raises_the_load_and_braking_drops_it() -> None:
    speed = np.full(3, 10.0)
    load = EngineBank().run(codes(CAR, CAR, TRUCK), speed, np.array([1.5, -2.0, 0.5])).load
    assert load[0] == pytest.approx(0.1 + 0.5 * (10 / 45) ** 2 + 1.5 / 3.0)
    assert load[1] == 0.0  # engine braking
    assert load[2] == pytest.approx(0.1 + 0.5 * (10 / 28) ** 2 + 0.5 / 1.0)


def test_tyre_noise_doubles_speed_for_about_ten_decibels_and_wet_roads_are_louder() -> None:
    tyres = TyreBank()
    dry = tyres.level_db(codes(CAR, CAR), np.array([13.89, 27.78]), 0.0)
    assert dry.tolist() == pytest.approx([84.0, 84.0 + 35 * math.log10(2)])  # +10.5 dB
    wet = tyres.level_db(codes(CAR), np.array([13.89]), 1.0)
    assert wet[0] == pytest.approx(89.0)
    assert not tyres.has_tyres[kind_code("pedestrian")] and tyres.has_tyres[BICYCLE]


def frame(rows: list[tuple[str, str, float, float, float, float]]) -> NpcFrame:
    """NPCs as (id, kind, x, y, vx, vy)."""
    array = np.zeros(len(rows), dtype=NPC_DTYPE)
    for k, name in enumerate(("x", "y", "vx", "vy"), start=2):
        array[name] = [r[k] for r in rows]
    array["kind"] = [kind_code(r[1]) for r in rows]
    return NpcFrame(0.0, [r[0] for r in rows], array)


def ego(node_id: str, x: float, y: float, vx: float = 0.0, kind: str = "car") -> EgoNow:
    return EgoNow(node_id, kind, x, y, 0.0, 0.0, vx, 0.0, 4.5, 1.8, 1.5, 1500.0)


def test_engines_ride_on_vehicles_tyres_only_when_rolling_and_bicycles_have_no_engine() -> None:
    npcs = frame(
        [("v1", "car", 0, 0, 10, 0), ("v2", "car", 5, 0, 0, 0), ("b1", "bicycle", 9, 0, 5, 0),
         ("p1", "pedestrian", 9, 9, 1, 0)]
    )  # fmt: skip
    sounds = ActorSounds([SirenSpec(vehicle="v2", pattern="yelp")])
    found = sounds.sources(0.0, actor_columns([ego("me", 0, 3, vx=10)], npcs), wetness=0.5)
    assert sorted(found.ids) == sorted(["me.engine", "me.tyres", "v1.engine", "v1.tyres",
                                        "v2.engine", "v2.siren", "b1.tyres"])  # fmt: skip
    by_id = dict(zip(found.ids, found.drive.tolist(), strict=True))
    assert by_id["v1.tyres"] == [10.0, 0.5] and by_id["v2.siren"] == [1.0, 0.0]  # yelp = 1
    assert found.owner[found.ids.index("me.engine")] == 0  # the first actor: the first ego


def test_acceleration_is_the_change_of_speed_per_actor_between_calls() -> None:
    sounds = ActorSounds([])
    sounds.sources(0.0, actor_columns([], frame([("v1", "car", 0, 0, 10, 0)])), 0.0)
    later = frame([("v1", "car", 2.5, 0, 10.25, 0), ("v9", "car", 0, 0, 12, 0)])
    found = sounds.sources(0.25, actor_columns([], later), 0.0)
    load = dict(zip(found.ids, found.drive[:, 1].tolist(), strict=True))

    def cruise(v: float) -> float:
        return 0.1 + 0.5 * (v / 45) ** 2

    assert load["v1.engine"] == pytest.approx(cruise(10.25) + 1.0 / 3.0)  # 1 m/s² of 3 m/s²
    assert load["v9.engine"] == pytest.approx(cruise(12.0))  # new: no acceleration known
    same = frame([("v1", "car", 5.0, 0, 10.5, 0), ("v9", "car", 3, 0, 11.5, 0)])
    found = sounds.sources(0.5, actor_columns([], same), 0.0)  # same actors, same order
    load = dict(zip(found.ids, found.drive[:, 1].tolist(), strict=True))
    assert load["v1.engine"] == pytest.approx(cruise(10.5) + 1.0 / 3.0)
    assert load["v9.engine"] == 0.0  # slowing down at 2 m/s²: no load


def point_sources(levels: list[float], xs: list[float]) -> SoundSources:
    """Engines of the given levels at 1 m, along the x axis."""
    pos = np.column_stack([xs, np.zeros(len(xs)), np.zeros(len(xs))])
    ids = [f"s{i}" for i in range(len(xs))]
    return SoundSources.build(ids, 0, pos, np.array(levels), np.zeros((len(xs), 2)))


def test_audible_keeps_the_cap_above_the_threshold_loudest_first() -> None:
    # At 10 m every level drops 20 dB: 30, 50, 0, 45, 60, 20 dB at the ear.
    shared = point_sources([50.0, 70.0, 20.0, 65.0, 80.0, 40.0], [10.0] * 6)
    none = SoundSources.build([], 0, np.zeros((0, 3)), np.zeros(0), np.zeros((0, 2)))
    ears = np.zeros((1, 3))
    heard = audible(ears, shared, none, threshold_db=10.0, cap=3)
    assert heard.sources.ids == ["s4", "s1", "s3"] and heard.bounds.tolist() == [0, 3]
    assert audible(ears, shared, none, 40.0, 10).sources.ids == ["s4", "s1", "s3"]
    assert audible(ears, shared, none, 70.0, 10).sources.ids == []


def test_a_listeners_own_rows_compete_with_the_shared_ones() -> None:
    shared = point_sources([70.0, 60.0], [10.0, 10.0])  # 50 and 40 dB at the first ear
    rain_db = np.array([45.0, 55.0])  # around each of the two listeners
    own = SoundSources.build(["rain"] * 2, KIND_INDEX["rain"], np.zeros((2, 3)), rain_db,
                             np.zeros((2, 2)), listener=np.array([0, 1]))  # fmt: skip
    ears = np.array([[0.0, 0.0, 0.0], [5000.0, 0.0, 0.0]])
    heard = audible(ears, shared, own, threshold_db=30.0, cap=2)
    assert heard.sources.ids[heard.of(0)] == ["s0", "rain"]  # 50 > 45 > 40 dB: capped at 2
    assert heard.sources.ids[heard.of(1)] == []  # its rain is at 5 km, the engines too


def test_a_listener_hears_by_inverse_distance_and_never_its_own_actor() -> None:
    npcs = frame([("v1", "car", 10, 0, 0, 0), ("v2", "car", 1000, 0, 0, 0)])
    egos = [ego("me", 0, 0), ego("other", 990, 0)]
    found = ActorSounds([]).sources(0.0, actor_columns(egos, npcs), 0.0)
    ears = np.array([[0.0, 0.0, 0.0], [990.0, 0.0, 0.0]])
    none = SoundSources.build([], 0, np.zeros((0, 3)), np.zeros(0), np.zeros((0, 2)))
    heard = audible(ears, found, none, threshold_db=40.0, cap=8)
    # 68 dB idle − 20 dB at 10 m; each hears the other NPC's engine, neither its own engine
    assert heard.sources.ids[heard.of(0)] == ["v1.engine"]
    assert heard.sources.ids[heard.of(1)] == ["v2.engine"]
    just_above = audible(ears[:1], found, none, threshold_db=47.9, cap=8).sources.ids
    just_below = audible(ears[:1], found, none, threshold_db=48.1, cap=8).sources.ids
    assert just_above == ["v1.engine"] and just_below == []  # 48 dB at the ear


def test_humans_hear_each_others_car_and_bicycle_but_not_their_own() -> None:
    egos = [ego("driver", 0, 0, vx=10), ego("rider", 5, 0, vx=5, kind="bicycle"),
            ego("walker", 0, 5, kind="pedestrian")]  # fmt: skip
    scenes = SoundPublisher(AudioSpec(), []).scenes(0.0, egos, frame([]), None)
    heard = {s.listener: sorted(e.id for e in s.emitters) for s in scenes}
    assert heard == {
        "driver": ["rider.tyres"],
        "rider": ["driver.engine", "driver.tyres"],
        "walker": ["driver.engine", "driver.tyres", "rider.tyres"],
    }


SQUARE = [(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)]


def test_an_area_is_heard_from_its_nearest_point_or_all_around_inside_it() -> None:
    areas = MapAreaSources(
        [MapArea("park", "vegetation", SQUARE), MapArea("b", "building", SQUARE)]
    )
    assert areas.ids == ["park.leaves"] and areas.extent_m[0] == pytest.approx(
        20 / math.sqrt(math.pi)
    )
    ears = np.array([[30.0, 10.0], [5.0, 7.0], [300.0, 10.0]])
    listener, area, points = areas.nearest(ears, np.array([50.0]))
    assert listener.tolist() == [0, 1] and area.tolist() == [0, 0]  # the third is out of reach
    assert points.tolist() == [[20.0, 10.0], [5.0, 7.0]]  # inside: it surrounds the listener


def test_construction_sits_on_its_rim_and_rain_and_wind_follow_the_weather() -> None:
    zone = ConstructionZone(name="dig", x=100.0, y=0.0, radius_m=10.0)
    around = ListenerAreas([], [zone])
    dry = around.sources(np.array([[0.0, 0.0, 0.0], [102.0, 3.0, 0.0]]), Weather(1, 0.0), 30.0)
    assert dry.ids == ["construction.dig"] * 2 and dry.listener.tolist() == [0, 1]
    assert dry.pos.tolist() == [[90.0, 0.0, 0.0], [102.0, 3.0, 0.0]]  # on the rim, or inside
    wet = Weather(2, 0.0, precipitation=0.5, wind_speed_mps=9.0)
    found = around.sources(np.array([[0.0, 0.0, 1.0]]), wet, 30.0)
    rain = found.ids.index("weather.rain")
    assert found.level_db[rain] == pytest.approx(60.0) and found.drive[rain, 0] == 0.5
    assert found.pos[rain].tolist() == [0.0, 0.0, 1.0] and found.extent_m[rain] > 0
    wind = found.ids.index("weather.wind")
    assert found.level_db[wind] == pytest.approx(35 + 40 * math.log10(4.0))


def test_every_scene_is_valid_on_the_wire_and_capped() -> None:
    rng = np.random.default_rng(3)
    kinds = ["car", "van", "truck", "bus", "motorcycle", "bicycle", "pedestrian", "other"]
    rows = [(f"v{i}", kinds[i % 8], *rng.uniform(-200, 200, 2), *rng.uniform(-20, 20, 2))
            for i in range(300)]  # fmt: skip
    spec = AudioSpec(max_emitters=16, sirens=[SirenSpec(vehicle="v3")])
    publisher = SoundPublisher(spec, [MapArea("lake", "water", SQUARE)])
    listeners = [ego(f"n{i}", *rng.uniform(-200, 200, 2)) for i in range(5)]
    weather = Weather(1, 0.0, precipitation=1.0, wetness=1.0, wind_speed_mps=30.0)
    for t in (0.0, 0.05):
        scenes = publisher.scenes(t, listeners, frame(rows), weather)
    for scene in scenes:
        assert len(scene.emitters) == 16
        assert AUDIO_SCENE.decode(AUDIO_SCENE.encode(scene)) == scene
    assert {e.kind for s in scenes for e in s.emitters} >= {"engine", "tyres", "rain", "wind"}


def test_scenes_go_out_at_the_audio_rate_from_a_faster_tick_and_not_when_disabled() -> None:
    egos = [ego("a", 0, 0), ego("b", 10, 0)]
    out = MemoryOutbox()
    publisher = SoundPublisher(AudioSpec(rate_hz=20.0), [])
    for k in range(500):  # ten seconds of a 50 Hz authority tick
        publisher.tick(1000.0 + k * 0.02, egos, frame([]), None, out)
    times = [scene.t for node, scene in out.audio_scenes if node == "a"]
    assert len(times) == 201 and publisher.stats.scenes == 2 * 201  # 20 Hz, and one at t = 0
    assert max(np.diff(times)) == pytest.approx(0.06)  # never late by more than one tick
    quiet = MemoryOutbox()
    SoundPublisher(AudioSpec(enabled=False), []).tick(0.0, egos, frame([]), None, quiet)
    SoundPublisher(AudioSpec(), []).tick(0.0, [], frame([]), None, quiet)  # nobody to hear
    assert quiet.audio_scenes == []
