"""Audio at hundreds of listeners: the fast selection equals the plain rule, and phase groups
spread the scenes over the ticks without changing any listener's rate.

The reference is the selection written one listener at a time, as the module docstring of
sound_audibility states it: free-field level of every source, not the listener's own actor,
at or above the threshold, loudest `cap` first.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse.authority.actors import EgoNow
from carlaverse.authority.memory_outbox import MemoryOutbox
from carlaverse.authority.sound_audibility import MIN_DISTANCE_M, audible
from carlaverse.authority.sound_publisher import SoundPublisher
from carlaverse.authority.sound_schedule import GROUP_MIN_LISTENERS, PhaseGroups
from carlaverse.authority.sound_sources import KIND_INDEX, SoundSources
from carlaverse.messages import NPC_DTYPE, MapArea, Weather
from carlaverse.traffic.engine import NpcFrame, kind_code
from carlaverse.traffic.soundscape import AudioSpec, ConstructionZone, SirenSpec

THRESHOLD_DB, CAP = 30.0, 32
TICK_S = 0.02  # [s] the authority's 50 Hz tick
RATE_HZ = 20.0  # [Hz] scenes per listener


def reference(
    ears: np.ndarray, actors: np.ndarray, shared: SoundSources, own: SoundSources
) -> list[list[tuple[int, float]]]:
    """Per listener, (pool row, level [dB]) of what it hears, loudest first: one at a time."""
    heard = []
    for i, ear in enumerate(ears):
        rows = [r for r in range(len(shared)) if shared.owner[r] != actors[i]]
        rows += [len(shared) + r for r in range(len(own)) if own.listener[r] == i]
        found = []
        for row in rows:
            pool, r = (shared, row) if row < len(shared) else (own, row - len(shared))
            d2 = max(float(((pool.pos[r] - ear) ** 2).sum()), MIN_DISTANCE_M**2)
            level = float(pool.level_db[r]) - 10.0 * math.log10(d2)
            if level >= THRESHOLD_DB:
                found.append((row, level))
        heard.append(sorted(found, key=lambda f: -f[1])[:CAP])
    return heard


def town(rng: np.random.Generator, listeners: int, vehicles: int) -> tuple[np.ndarray, ...]:
    """Listeners in a 2 km square and a few far out of town; vehicles both spread over the
    square and packed around listeners (some within 1 m), each with an engine and tyres."""
    ears = rng.uniform(0, 2000, (listeners, 3))
    ears[:, 2] = rng.uniform(0, 3, listeners)
    ears[-3:, 0] += 20_000  # out of town: hears sirens, its own rows, nothing else
    spread = rng.uniform(0, 2000, (vehicles // 2, 3))
    near = ears[rng.integers(0, listeners, vehicles - len(spread))]
    near = near + rng.normal(0, 1, near.shape) * rng.choice([0.3, 5.0, 60.0], (len(near), 1))
    cars = np.concatenate([ears, spread, near])  # the listeners' own cars come first
    return ears, cars


def sources_on(rng: np.random.Generator, cars: np.ndarray, sirens: int) -> SoundSources:
    n = len(cars)
    owner = np.concatenate([np.arange(n), np.arange(n), rng.choice(n, sirens, replace=False)])
    level = np.concatenate([rng.uniform(60, 100, n), rng.uniform(35, 95, n), np.full(sirens, 118)])
    kind = np.concatenate([np.full(n, KIND_INDEX["engine"]), np.full(n, KIND_INDEX["tyres"]),
                           np.full(sirens, KIND_INDEX["siren"])])  # fmt: skip
    ids = [f"s{i}" for i in range(len(owner))]
    return SoundSources.build(ids, kind, cars[owner], level, np.zeros((len(owner), 2)), owner=owner)


def own_rows(rng: np.random.Generator, ears: np.ndarray) -> SoundSources:
    """Up to four rows per listener (areas, rain), near it or far."""
    listener = np.repeat(np.arange(len(ears)), rng.integers(0, 5, len(ears)))
    pos = ears[listener] + rng.normal(0, 40, (len(listener), 3))
    level = rng.uniform(40, 75, len(listener))
    ids = [f"own{i}" for i in range(len(listener))]
    kind = KIND_INDEX["leaves"]
    return SoundSources.build(ids, kind, pos, level, np.zeros((len(ids), 2)), listener=listener)


@pytest.mark.parametrize("seed", range(4))
def test_the_selection_equals_the_one_listener_at_a_time_rule(seed: int) -> None:
    rng = np.random.default_rng(seed)
    ears, cars = town(rng, listeners=60, vehicles=500)
    shared, own = sources_on(rng, cars, sirens=3), own_rows(rng, ears)
    # A phase group: every other listener, riding on its own actor (listener i is actor 2i).
    actors = np.arange(0, len(ears), 2)
    group_ears, group_own = ears[actors], own_rows(rng, ears[actors])
    for e, a, o in ((ears, np.arange(len(ears)), own), (group_ears, actors, group_own)):
        heard = audible(e, shared, o, THRESHOLD_DB, CAP, actors=a)
        want = reference(e, a, shared, o)
        for i, chosen in enumerate(want):
            assert heard.rows[heard.of(i)].tolist() == [row for row, _ in chosen], f"listener {i}"
        assert max(map(len, want)) == CAP and min(map(len, want)) < CAP  # capped and not


def frame(rng: np.random.Generator, n: int) -> NpcFrame:
    rows = np.zeros(n, dtype=NPC_DTYPE)
    rows["x"], rows["y"] = rng.uniform(0, 600, (2, n))
    rows["vx"], rows["vy"] = rng.uniform(-12, 12, (2, n))
    rows["kind"] = kind_code("car")
    return NpcFrame(0.0, [f"npc{i}" for i in range(n)], rows)


def ego(node_id: str, x: float, y: float) -> EgoNow:
    return EgoNow(node_id, "car", x, y, 0.0, 0.0, 8.0, 0.0, 4.5, 1.8, 1.5, 1500.0)


def test_a_phase_group_hears_what_it_would_hear_with_everyone_at_once() -> None:
    rng = np.random.default_rng(11)
    zone = ConstructionZone(name="dig", x=300, y=300, radius_m=12)
    spec = AudioSpec(sirens=[SirenSpec(vehicle="npc3")], construction=[zone])
    areas = [MapArea("park", "vegetation", [(100, 100), (160, 100), (160, 170), (100, 170)])]
    egos = [ego(f"e{i}", *rng.uniform(0, 600, 2)) for i in range(40)]
    npcs, weather = frame(rng, 300), Weather(1, 0.0, precipitation=0.4, wind_speed_mps=7.0)
    everyone = SoundPublisher(spec, areas).scenes(0.0, egos, npcs, weather)
    group = np.array([1, 4, 5, 17, 39])
    some = SoundPublisher(spec, areas).scenes(0.0, egos, npcs, weather, only=group)
    assert some == [everyone[i] for i in group.tolist()]


def run_ticks(groups: PhaseGroups, ids: list[str], ticks: int, t0: float = 0.0) -> list[list[str]]:
    """The listeners served at each of `ticks` 50 Hz ticks."""
    return [[ids[i] for i in groups.due(t0 + k * TICK_S, ids)] for k in range(ticks)]


def served_times(served: list[list[str]], node_id: str, t0: float = 0.0) -> np.ndarray:
    return np.array([t0 + k * TICK_S for k, ids in enumerate(served) if node_id in ids])


@pytest.mark.parametrize("listeners", [2, 31, 64, 256, 257])
def test_each_listener_hears_at_the_rate_and_no_tick_carries_more_than_its_group(
    listeners: int,
) -> None:
    ids = [f"n{i}" for i in range(listeners)]
    groups = PhaseGroups(RATE_HZ)
    served = run_ticks(groups, ids, ticks=500)  # ten seconds
    expected = 1 if listeners < 2 * GROUP_MIN_LISTENERS else 2  # 2.5 ticks per period
    assert groups.groups == expected
    assert max(len(s) for s in served) == math.ceil(listeners / expected)
    for node_id in ids:
        times = served_times(served, node_id)
        gaps = np.diff(times)
        assert times[0] <= 1 / RATE_HZ  # its phase comes within the first period
        assert (
            gaps.min() >= 1 / RATE_HZ - TICK_S - 1e-9 and gaps.max() <= 1 / RATE_HZ + TICK_S + 1e-9
        )
        assert len(times) == pytest.approx(10 * RATE_HZ, abs=1)
    if expected == 1:  # a handful: everyone together, from the first tick, as before
        assert served[0] == ids and all(s in ([], ids) for s in served)


def test_joiners_and_leavers_keep_the_groups_even_and_the_others_on_their_beat() -> None:
    ids = [f"n{i}" for i in range(100)]
    groups = PhaseGroups(RATE_HZ)
    run_ticks(groups, ids, ticks=50)
    stay = ids[:60]
    later = [*stay, *(f"m{i}" for i in range(30))]  # 40 left, 30 joined
    served = run_ticks(groups, later, ticks=250, t0=50 * TICK_S)
    assert max(len(s) for s in served[5:]) <= math.ceil(len(later) / 2)
    for node_id in later:
        gaps = np.diff(served_times(served, node_id, t0=50 * TICK_S)[1:])  # after one re-deal
        assert gaps.max() <= 1 / RATE_HZ + TICK_S + 1e-9, node_id


def test_scenes_go_out_per_phase_group_through_the_publisher() -> None:
    rng = np.random.default_rng(5)
    egos = [ego(f"e{i}", *rng.uniform(0, 600, 2)) for i in range(64)]
    npcs, out = frame(rng, 100), MemoryOutbox()
    publisher = SoundPublisher(AudioSpec(), [])
    per_tick = []
    for k in range(100):  # two seconds at 50 Hz
        before = len(out.audio_scenes)
        publisher.tick(k * TICK_S, egos, npcs, None, out)
        per_tick.append(len(out.audio_scenes) - before)
    assert max(per_tick) == 32 and publisher.stats.scenes == len(out.audio_scenes)
    for e in egos:
        times = [s.t for node, s in out.audio_scenes if node == e.node_id]
        assert len(times) == pytest.approx(2 * RATE_HZ, abs=1)
        assert max(np.diff(times)) <= 1 / RATE_HZ + TICK_S + 1e-9


def test_no_scene_is_built_for_a_listener_nothing_takes_audio_for() -> None:
    rng = np.random.default_rng(6)
    egos = [ego(f"e{i}", *rng.uniform(0, 600, 2)) for i in range(64)]
    npcs = frame(rng, 100)
    deaf = {f"e{i}" for i in range(64) if i % 4}  # three in four render no audio
    out = MemoryOutbox(deaf=deaf)
    publisher = SoundPublisher(AudioSpec(), [])
    for k in range(50):
        publisher.tick(k * TICK_S, egos, npcs, None, out)
    heard = {node for node, _ in out.audio_scenes}
    assert heard == {e.node_id for e in egos} - deaf
    assert publisher.stats.scenes == len(out.audio_scenes) == pytest.approx(16 * RATE_HZ, abs=16)
    # Everyone deaf: the tick builds nothing at all.
    silent = MemoryOutbox(deaf={e.node_id for e in egos})
    for k in range(50):
        publisher.tick(1.0 + k * TICK_S, egos, npcs, None, silent)
    assert silent.audio_scenes == [] and silent.bytes_sent == 0
