"""Sound models and audibility, worked by hand: engines, tyres, areas, weather, the cap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse.authority.actors import EgoNow
from carlaverse.authority.sound_areas import ListenerAreas, MapAreaSources
from carlaverse.authority.sound_audibility import audible_on_actors, loudest
from carlaverse.authority.sound_models import EngineBank, TyreBank
from carlaverse.authority.sound_publisher import SoundPublisher
from carlaverse.authority.sound_sources import ActorSounds, actor_columns
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
    assert found.owner[found.ids.index("me.engine")] == "me"


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


def test_loudest_keeps_the_cap_above_the_threshold_loudest_first() -> None:
    levels = np.array([50.0, 70.0, 20.0, 65.0, 80.0, 40.0])
    assert loudest(levels, 30.0, 3).tolist() == [4, 1, 3]
    assert loudest(levels, 60.0, 10).tolist() == [4, 1, 3]
    assert loudest(levels, 90.0, 10).tolist() == []


def test_a_listener_hears_by_inverse_distance_and_never_its_own_actor() -> None:
    npcs = frame([("v1", "car", 10, 0, 0, 0), ("v2", "car", 1000, 0, 0, 0)])
    found = ActorSounds([]).sources(0.0, actor_columns([ego("me", 0, 0)], npcs), 0.0)
    ears = np.array([[0.0, 0.0, 0.0], [990.0, 0.0, 0.0]])
    heard = audible_on_actors(ears, ["me", "other"], found, threshold_db=40.0, cap=8)
    (near, near_db), (far, _) = heard
    assert [found.ids[i] for i in near] == ["v1.engine"]  # 68 dB − 20 dB at 10 m; own engine out
    assert near_db.tolist() == pytest.approx([48.0])
    assert [found.ids[i] for i in far] == ["v2.engine"]  # 68 − 20·log10(10) again, at 10 m


SQUARE = [(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)]


def test_an_area_is_heard_from_its_nearest_point_or_all_around_inside_it() -> None:
    areas = MapAreaSources(
        [MapArea("park", "vegetation", SQUARE), MapArea("b", "building", SQUARE)]
    )
    assert areas.ids == ["park.leaves"] and areas.extent_m[0] == pytest.approx(
        20 / math.sqrt(math.pi)
    )
    idx, points = areas.nearest(np.array([30.0, 10.0]), np.array([50.0]))
    assert idx.tolist() == [0] and points.tolist() == [[20.0, 10.0]]
    idx, points = areas.nearest(np.array([5.0, 7.0]), np.array([50.0]))
    assert points.tolist() == [[5.0, 7.0]]  # inside: it surrounds the listener
    idx, _ = areas.nearest(np.array([300.0, 10.0]), np.array([50.0]))
    assert idx.tolist() == []


def test_construction_sits_on_its_rim_and_rain_and_wind_follow_the_weather() -> None:
    zone = ConstructionZone(name="dig", x=100.0, y=0.0, radius_m=10.0)
    around = ListenerAreas([], [zone])
    dry = around.sources(np.array([0.0, 0.0, 0.0]), Weather(1, 0.0), 30.0)
    assert dry.ids == ["construction.dig"] and dry.pos.tolist() == [[90.0, 0.0, 0.0]]
    wet = Weather(2, 0.0, precipitation=0.5, wind_speed_mps=9.0)
    found = around.sources(np.array([0.0, 0.0, 1.0]), wet, 30.0)
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
