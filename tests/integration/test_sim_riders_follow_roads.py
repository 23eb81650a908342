"""The demo's simulated driver and rider keep to the town's roads (issue 42 item 7).

A real demo (router, the authority running SUMO on the town's map, a drive and a bike node
on `--backend sim`, the recorder) for 20 s; the recording read back. Every pose of the car
must lie on a lane open to cars, every pose of the bike on one open to bicycles, at the
right edge of its lane, none inside a building, and both must have gone somewhere. The
town's traffic is left out (the scripted driver does not yield, and an NPC's collision
impulse would throw the car off its lane for reasons that are not the route's).
"""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from carlaverse import keys as keyspace
from carlaverse import messages as m
from carlaverse.config import shipped_dir
from carlaverse.geometry import inside_polygon
from carlaverse.recording.reading import iter_samples, recorded_map

DURATION_S = 20.0
# The pose is the vehicle's reference point (the car's centre of gravity, the bike's). Half
# a metre past a lane's edge is allowed: pure pursuit cuts a bend by about l_d²/(2R); the
# car's slow junction turns (R ≈ 5.7 m at ≤ 4 m/s, look-ahead 0.8 s · 4 m/s = 3.2 m) cut
# ~0.9 m, which stays over the junction's other internal lanes but may touch an edge.
EDGE_MARGIN_M = 0.5
# A rider keeps BIKE_EDGE_M = 0.8 m from a road lane's right edge (traffic.lane_route): on
# the town's 3.2 m lanes, 0.8 m right of the centre line. Pure pursuit settles on a straight
# lane to within centimetres; 0.3 m covers the overshoot after a turn (~0.2 m).
BIKE_EDGE_M, BIKE_TOLERANCE_M = 0.8, 0.3
# Going somewhere: the car accelerates to its 12 m/s and slows to ~4 m/s for junction turns,
# the rider pedals the simulated trainer's 180 W (~7 m/s on the flat); after the join (a few
# seconds of the 20) each covers far more than these unless it stands or circles in place.
MIN_CAR_M, MIN_BIKE_M = 100.0, 60.0


def quiet_town(directory: Path) -> Path:
    """The shipped town (its map and spawns) without its NPC traffic."""
    town = yaml.safe_load((shipped_dir("carlaverse.scenarios") / "town.yaml").read_text())
    town["name"] = "quiet-town"
    town["traffic"] = {"vehicles": {"count": 0}, "pedestrians": {"count": 0}}
    town.pop("audio", None)  # its siren follows the ambulance, which is traffic
    path = directory / "quiet-town.yaml"
    path.write_text(yaml.safe_dump(town))
    return path


def open_to(lane: m.MapLane, vehicle_class: str) -> bool:
    """A lane the class may use: a road lane that allows it, or (bicycles) a bike lane."""
    if vehicle_class == "bicycle" and lane.kind == "bike":
        return True
    return lane.kind == "road" and (not lane.allow or vehicle_class in lane.allow)


class Lanes:
    """The centre-line segments of some lanes, for the distance of a point to each."""

    def __init__(self, lanes: list[m.MapLane]) -> None:
        rows = [(lane, a, b) for lane in lanes for a, b in itertools.pairwise(lane.centerline)]
        self.lanes = [lane for lane, _, _ in rows]
        self.a = np.array([a for _, a, _ in rows], dtype=float)
        self.d = np.array([b for _, _, b in rows], dtype=float) - self.a
        self.half = np.array([lane.width / 2 for lane in self.lanes])

    def nearest(self, x: float, y: float) -> tuple[float, float, m.MapLane]:
        """(distance beyond the nearest lane's edge [m], signed offset to the right of its
        centre line [m], that lane)."""
        p = np.array([x, y])
        t = np.clip(((p - self.a) * self.d).sum(1) / np.maximum((self.d**2).sum(1), 1e-12), 0, 1)
        gap = p - (self.a + t[:, None] * self.d)
        distance = np.hypot(gap[:, 0], gap[:, 1])
        i = int(np.argmin(distance - self.half))
        right = (gap[i, 0] * self.d[i, 1] - gap[i, 1] * self.d[i, 0]) / np.hypot(*self.d[i])
        return float(distance[i] - self.half[i]), float(right), self.lanes[i]


def recorded_poses(path: Path) -> dict[str, list[m.Pose]]:
    poses: dict[str, list[m.Pose]] = {}
    for sample in iter_samples(path):
        key = keyspace.parse(sample.key)
        if sample.kind == "put" and key.area == "ego" and key.channel == "pose":
            poses.setdefault(key.node_id, []).append(m.POSE.decode(sample.payload))
    return poses


def distances(poses: list[m.Pose]) -> list[float]:
    """[m] travelled up to each pose."""
    steps = [math.hypot(b.x - a.x, b.y - a.y) for a, b in itertools.pairwise(poses)]
    return [0.0, *np.cumsum(steps).tolist()]


def travelled(poses: list[m.Pose]) -> float:
    return distances(poses)[-1]


@pytest.mark.timeout(180)
def test_the_demos_sim_driver_and_rider_follow_the_roads(tmp_path: Path) -> None:
    recording = tmp_path / "demo.mcap"
    argv = [sys.executable, "-m", "carlaverse", "demo", "--nodes", "drive,bike",
            "--scenario", str(quiet_town(tmp_path)), "--duration", str(DURATION_S),
            "--record", str(recording), "--json", "--quiet"]  # fmt: skip
    done = subprocess.run(argv, capture_output=True, text=True, timeout=170, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout)["ok"]
    road_map = recorded_map(recording)
    assert road_map is not None, "the recording has no map"
    buildings = [area.polygon for area in road_map.areas if area.kind == "building"]
    assert buildings, "the town has buildings to stay out of"
    poses = recorded_poses(recording)

    car = poses["drive-1"]
    car_lanes = Lanes([lane for lane in road_map.lanes if open_to(lane, "passenger")])
    beyond = [car_lanes.nearest(p.x, p.y)[0] for p in car]
    assert max(beyond) <= EDGE_MARGIN_M, f"the car left its lanes by {max(beyond):.2f} m"
    assert travelled(car) > MIN_CAR_M, f"the car went {travelled(car):.0f} m"
    # through a junction onto another street: lanes the map connects, in order
    streets = [car_lanes.nearest(p.x, p.y)[2] for p in car]
    first = streets[0]
    assert any(lane.id in first.successors for lane in streets), [first.id, streets[-1].id]

    bike = poses["bike-2"]
    bike_lanes = Lanes([lane for lane in road_map.lanes if open_to(lane, "bicycle")])
    places = [bike_lanes.nearest(p.x, p.y) for p in bike]
    worst = max(beyond for beyond, _, _ in places)
    assert worst <= EDGE_MARGIN_M, f"the bike left its lanes by {worst:.2f} m"
    assert travelled(bike) > MIN_BIKE_M, f"the bike went {travelled(bike):.0f} m"
    # at the right edge of its road lane wherever it is not crossing a junction, once it has
    # left the spawn (on the centre line): pure pursuit closes such an offset within about
    # three look-ahead lengths (15 m)
    junctions = [area.polygon for area in road_map.areas if area.kind == "junction"]
    walked = distances(bike)
    on_street = [
        (right, lane) for p, (_, right, lane), w in zip(bike, places, walked, strict=True)
        if w > 15.0 and lane.kind == "road"
        and not any(inside_polygon(j, p.x, p.y) for j in junctions)
    ]  # fmt: skip
    assert len(on_street) > len(bike) // 2
    offsets = [right - (lane.width / 2 - BIKE_EDGE_M) for right, lane in on_street]
    assert max(abs(o) for o in offsets) < BIKE_TOLERANCE_M, max(offsets, key=abs)

    for node_id, track in (("drive-1", car), ("bike-2", bike)):
        inside = [p for p in track if any(inside_polygon(b, p.x, p.y) for b in buildings)]
        where = f"({inside[0].x:.1f}, {inside[0].y:.1f})" if inside else ""
        assert not inside, f"{node_id} drove into a building at {where}"
