"""A real demo session (authority, SUMO `town`, three scripted cars) recorded and exported to
OSI, read back with betterosi and held to the analysis, the recording and the demo's plan."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import betterosi
import pytest

from carlaverse import messages as m
from carlaverse.analysis.tracks import read_tracks
from carlaverse.cli import main
from carlaverse.keys import parse
from carlaverse.recording.reading import iter_samples, recorded_map
from tests.recorded_demo import RecordedDemo

RATE_HZ = 10.0
# demo_plan: scripted-i drives a circle about the origin of radius 25 + 6 (i - 1) m, at
# 14 m/s (i odd) or 12 m/s
RADII_M = {"scripted-1": 25.0, "scripted-2": 31.0, "scripted-3": 37.0}
SPEED_MPS = {"scripted-1": 14.0, "scripted-2": 12.0, "scripted-3": 14.0}


def chord_sag_m(recording: Path) -> dict[str, float]:
    """[m] how far inside its circle a straight line between two recorded poses of each car
    can fall: R (1 - cos(v gap / 2R)) for its longest gap (a loaded machine sends late)."""
    times: dict[str, list[float]] = {}
    for sample in iter_samples(recording):
        key = parse(sample.key)
        if (key.area, key.channel) == ("ego", "pose") and key.node_id in RADII_M:
            times.setdefault(key.node_id, []).append(m.POSE.decode(sample.payload).t)
    sag = {}
    for node, ts in times.items():
        ts.sort()
        gap = max((b - a for a, b in itertools.pairwise(ts) if b - a <= 0.5), default=0.0)
        r = RADII_M[node]
        sag[node] = r * (1 - math.cos(SPEED_MPS[node] * gap / (2 * r)))
    return sag


@pytest.fixture(scope="module")
def demo(
    tmp_path_factory: pytest.TempPathFactory, recorded_demo: RecordedDemo
) -> tuple[Path, list]:
    folder = tmp_path_factory.mktemp("osi-demo")
    recording, trace = recorded_demo.mcap, folder / "demo.osi.mcap"  # the suite's one demo
    assert main(["osi", str(recording), "-o", str(trace), "--osi-rate", str(RATE_HZ)]) == 0
    return recording, list(betterosi.read(str(trace), return_ground_truth=True))


def actor_of(obj) -> str:
    return obj.source_reference[0].identifier[0]


def seconds(frame) -> float:
    return frame.timestamp.seconds + frame.timestamp.nanos * 1e-9


def test_every_road_user_matches_the_analysis_and_the_cars_their_circles(demo) -> None:
    recording, frames = demo
    tracks = read_tracks(recording, rate_hz=RATE_HZ)
    assert len(frames) == len(tracks.t) > 25
    worst, samples, circle = 0.0, 0, 0.0
    sag = chord_sag_m(recording)
    for k, frame in enumerate(frames):
        # session time here counts from the epoch: a float64 of it resolves 0.24 µs
        assert abs(seconds(frame) - tracks.t[k]) < 1e-6
        seen = {actor_of(o): o for o in frame.moving_object}
        assert set(seen) == {a.id for i, a in enumerate(tracks.actors) if tracks.present[i, k]}
        for actor_id, obj in seen.items():
            i, p = tracks.index(actor_id), obj.base.position
            worst = max(worst, math.hypot(p.x - tracks.x[i, k], p.y - tracks.y[i, k]))
            samples += 1
            if actor_id in RADII_M:  # inside by at most the chord's sag, plus float32's mm
                off = abs(math.hypot(p.x, p.y) - RADII_M[actor_id])
                assert off < sag[actor_id] + 1e-3, (actor_id, off, sag[actor_id])
                circle = max(circle, off)
    assert worst < 1e-3, worst
    print(f"demo: {samples} object samples in {len(frames)} frames, max deviation from the "
          f"analysis {worst * 1e3:.6f} mm, from the circles {circle * 1e3:.2f} mm")  # fmt: skip


def test_kinds_sizes_map_and_signals_are_the_recording_s(demo) -> None:
    recording, frames = demo
    road_map = recorded_map(recording)
    assert road_map is not None
    assert len(frames[0].lane) == len(road_map.lanes)
    assert len(frames[0].lane_boundary) == 2 * len(road_map.lanes)
    # the NPC rows' own kinds and boxes, read without the export
    rows: dict[str, tuple[str, tuple[float, float, float]]] = {}
    lights: list[m.LightsState] = []
    for sample in iter_samples(recording):
        key = parse(sample.key)
        if (key.area, key.channel) == ("world", "npc"):
            batch = m.NPC_BATCH.decode(sample.payload)
            for npc, row in zip(batch.ids, batch.array(), strict=True):
                size = (float(row["length"]), float(row["width"]), float(row["height"]))
                rows.setdefault(npc, (m.ACTOR_KINDS[min(int(row["kind"]), 7)], size))
        elif (key.area, key.channel) == ("world", "lights"):
            lights.append(m.LIGHTS.decode(sample.payload))
    pedestrian, vehicle = betterosi.MovingObjectType.PEDESTRIAN, betterosi.MovingObjectType.VEHICLE
    kinds_seen = set()
    for obj in frames[len(frames) // 2].moving_object:
        actor = actor_of(obj)
        d = obj.base.dimension
        if actor in RADII_M:
            assert obj.type == vehicle and (d.length, d.width) == pytest.approx((4.5, 1.8))
            continue
        kind, size = rows[actor]
        kinds_seen.add(kind)
        assert obj.type == (pedestrian if kind == "pedestrian" else vehicle), actor
        assert (d.length, d.width, d.height) == pytest.approx(size), actor
    assert "pedestrian" in kinds_seen and "car" in kinds_seen
    # every signal link a head of three bulbs; the last frame's lit bulbs are the last state
    last = frames[-1]
    state = max((s for s in lights if s.t <= seconds(last)), key=lambda s: s.t)
    links = sum(len(light.controlled_lanes) for light in road_map.lights)
    assert len(last.traffic_light) == 3 * links
    colour = {"r": "RED", "y": "YELLOW", "g": "GREEN", "G": "GREEN"}
    on = betterosi.TrafficLightClassificationMode.CONSTANT
    lit = {(b.source_reference[0].identifier[0], int(b.source_reference[0].identifier[1]))
           : b.classification.color.name for b in last.traffic_light
           if b.classification.mode == on}  # fmt: skip
    expected = {(light.id, i): colour[c] for light in state.lights
                for i, c in enumerate(light.state) if c in colour}  # fmt: skip
    assert lit == expected
