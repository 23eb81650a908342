"""A recording's OSI ground truth, read back by independent OSI readers (betterosi, the ASAM
osi-utilities reader) and held to the project's analysis and to the synthetic world's truth.

The recording is written on the real keys as a recorder writes them: two egos on circles
(`synthetic.ego_pose`, 50 Hz), six NPCs on straight lanes (`npc_rows`, 10 Hz), the signal
cycling `GGrr, yyrr, rrGG, rryy` every 4 s (`light_state`), the cross-shaped map, and the
authority's snapshot and spawn events that name each ego's kind and size.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import betterosi
import numpy as np
import pytest
from mcap.reader import make_reader

from carlaverse import messages as m
from carlaverse.analysis.tracks import read_tracks
from carlaverse.cli import main
from carlaverse.keys import Keys
from carlaverse.recording.sink import McapSink
from carlaverse.recording.synthetic import (
    LIGHT_CYCLE_S,
    ego_pose,
    light_state,
    npc_rows,
    synthetic_map,
)

T0_NS = 1_700_000_000 * 10**9  # [ns] the recorder's wall clock at session time 0
SECONDS = 9.0  # [s] through three signal phases
RATE_HZ = 20.0
NPCS = 6
EGO_EXTENTS = {"ego-0": m.Extent(4.6, 1.9, 1.45), "ego-1": m.Extent(1.8, 0.6, 1.7)}
EGO_KINDS = {"ego-0": "car", "ego-1": "bicycle"}
# sun in the east, 30 degrees up; 3 mm/h of rain; 100 m visibility; half cloud; a west wind
WEATHER = m.Weather(1, 0.0, sun_altitude_deg=30.0, sun_azimuth_deg=90.0, cloudiness=0.5,
                    precipitation=0.3, fog_density=0.9, wind_speed_mps=4.0,
                    wind_direction_deg=270.0)  # fmt: skip
NPC0_LIGHTS = m.LIGHT_BRAKE | m.LIGHT_RIGHT_BLINKER  # npc-0 from t = 3 s
EGO0_STATES = [(2.0, m.LIGHT_LOW_BEAM, "left"), (5.0, m.LIGHT_PARKING, "hazard")]  # (t, bits, ...)


def write_recording(path: Path) -> None:
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    sink.write(keys.authority("map"), m.MAP.encode(synthetic_map()), T0_NS)
    egos = [m.EgoInfo(e, "scripted", EGO_KINDS[e], EGO_EXTENTS[e], 80.0) for e in EGO_KINDS]
    sink.write(keys.authority("snapshot"), m.SNAPSHOT.encode(m.Snapshot(2, 0.0, egos)), T0_NS)
    sink.write(keys.world("weather"), m.WEATHER.encode(WEATHER), T0_NS)
    for seq, ego in enumerate(EGO_KINDS, 1):
        event = m.Spawned(seq, 0.0, ego, "scripted", EGO_KINDS[ego])
        sink.write(keys.world("events"), m.WORLD_EVENT.encode(event), T0_NS)
    for k in range(int(SECONDS * 50) + 1):
        t = k / 50
        at = T0_NS + round(t * 1e9) + 3_000_000
        for i in range(2):
            sink.write(keys.pose(f"ego-{i}", "t0_0"), m.POSE.encode(ego_pose(i, k, t)), at)
        if k % 5 == 0:
            ids = [f"npc-{j}" for j in range(NPCS)]
            rows = npc_rows(NPCS, t)
            rows["lights"][0] = NPC0_LIGHTS if t >= 3.0 else 0
            batch = m.NpcBatch.pack(k, t, ids, rows)
            sink.write(keys.world("npc"), m.NPC_BATCH.encode(batch), at)
        if k % 50 == 0:
            sink.write(keys.world("lights"), m.LIGHTS.encode(light_state(k, t)), at)
        for when, lights, indicator in EGO0_STATES:
            if k == round(when * 50):
                state = m.EgoState(k, t, lights, indicator)
                sink.write(keys.ego("ego-0", "state"), m.EGO_STATE.encode(state), at)
    sink.close()


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, list]:
    folder = tmp_path_factory.mktemp("osi")
    recording, trace = folder / "session.mcap", folder / "session.osi.mcap"
    write_recording(recording)
    assert main(["osi", str(recording), "--osi-rate", str(RATE_HZ)]) == 0  # default: beside
    frames = list(betterosi.read(str(trace), return_ground_truth=True))
    return recording, trace, frames


def actor_of(obj) -> str:
    (ref,) = obj.source_reference
    assert ref.type == "net.carlaverse.actor"
    return ref.identifier[0]


def seconds(frame) -> float:
    return frame.timestamp.seconds + frame.timestamp.nanos * 1e-9


def test_every_trajectory_matches_the_analysis_within_a_millimetre(exported) -> None:
    recording, _, frames = exported
    tracks = read_tracks(recording, rate_hz=RATE_HZ)  # the project's own analysis
    assert len(frames) == len(tracks.t) == int(SECONDS * RATE_HZ) + 1
    worst, compared = 0.0, 0
    for k, frame in enumerate(frames):
        assert abs(seconds(frame) - tracks.t[k]) < 1e-9
        seen = {actor_of(o): o for o in frame.moving_object}
        present = {a.id for i, a in enumerate(tracks.actors) if tracks.present[i, k]}
        assert set(seen) == present, k
        for actor_id, obj in seen.items():
            i = tracks.index(actor_id)
            p = obj.base.position
            worst = max(worst, math.hypot(p.x - tracks.x[i, k], p.y - tracks.y[i, k]))
            assert (
                abs(math.remainder(obj.base.orientation.yaw - tracks.yaw[i, k], 2 * math.pi)) < 1e-6
            )
            assert obj.base.velocity.x == pytest.approx(tracks.vx[i, k], abs=1e-6)
            assert obj.base.velocity.y == pytest.approx(tracks.vy[i, k], abs=1e-6)
            compared += 1
    assert compared == len(frames) * (2 + NPCS)
    assert worst < 1e-3, f"max deviation {worst * 1e3:.4f} mm"
    print(f"OSI vs analysis: {compared} object samples, max deviation {worst * 1e3:.6f} mm")


def test_egos_follow_their_circles_in_osi_frame_and_signs(exported) -> None:
    # The truth is the synthetic world's formula (synthetic.ego_pose): ego i on a circle of
    # radius 20 + 5 i about the origin, counter-clockwise at 10 m/s from angle i. Sampled at
    # 50 Hz and interpolated linearly, the chord falls inside the arc by at most
    # R (w dt)^2 / 8 = 0.25 mm (R 20 m, w 0.5 rad/s, dt 0.02 s); float32 adds microns.
    # OSI's box reference point is half the height above the ground (OSI BaseMoving), a yaw
    # counter-clockwise from +x (a left turn) is positive and grows, and the velocity is along
    # the heading; a circle's acceleration is v^2 / R towards its centre.
    _, _, frames = exported
    worst = 0.0
    for frame in frames[1:-1]:
        t = seconds(frame)
        for obj in frame.moving_object:
            actor = actor_of(obj)
            if not actor.startswith("ego-"):
                continue
            i = int(actor[-1])
            radius, a = 20.0 + 5.0 * i, 10.0 / (20.0 + 5.0 * i) * t + i
            b = obj.base
            worst = max(worst, math.hypot(b.position.x - radius * math.cos(a),
                                          b.position.y - radius * math.sin(a)))  # fmt: skip
            assert b.position.z == pytest.approx(EGO_EXTENTS[actor].height / 2)
            heading = math.atan2(b.velocity.y, b.velocity.x)
            assert math.remainder(b.orientation.yaw - heading, 2 * math.pi) == pytest.approx(
                0, abs=1e-5
            )
            assert (
                b.orientation_rate.yaw == pytest.approx(10.0 / radius, rel=1e-3)
                and b.orientation_rate.yaw > 0
            )
            radial = b.acceleration.x * math.cos(a) + b.acceleration.y * math.sin(a)
            assert radial == pytest.approx(-100.0 / radius, rel=0.01)
    assert worst < 1e-3, f"{worst * 1e3:.4f} mm off the circle"
    print(f"OSI vs the synthetic circles: max deviation {worst * 1e3:.4f} mm")


def test_types_dimensions_and_host(exported) -> None:
    _, _, frames = exported
    frame = frames[10]
    objects = {actor_of(o): o for o in frame.moving_object}
    vehicle, types = (
        betterosi.MovingObjectType.VEHICLE,
        betterosi.MovingObjectVehicleClassificationType,
    )
    expected = {"ego-0": (vehicle, types.MEDIUM_CAR), "ego-1": (vehicle, types.BICYCLE)}
    npc_types = ("MEDIUM_CAR", "DELIVERY_VAN", "HEAVY_TRUCK")  # npc_rows: kind = i % 3
    for j in range(NPCS):
        expected[f"npc-{j}"] = (vehicle, getattr(types, npc_types[j % 3]))
    for actor, (kind, vehicle_type) in expected.items():
        obj = objects[actor]
        assert obj.type == kind and obj.vehicle_classification.type == vehicle_type, actor
        d = obj.base.dimension
        size = EGO_EXTENTS.get(actor, m.Extent(4.5, 1.8, 1.5))  # npc_rows' boxes
        assert (d.length, d.width, d.height) == pytest.approx(
            (size.length, size.width, size.height)
        )
    assert frame.host_vehicle_id.value == objects["ego-0"].id.value
    assert len({o.id.value for o in frame.moving_object}) == len(objects)


def test_lanes_with_boundaries_half_a_width_either_side(exported) -> None:
    # synthetic_map's lane x_0 runs east along y = -1.75, 3.5 m wide: facing east, left is
    # north, so its left boundary lies on y = 0 and its right on y = -3.5.
    _, _, frames = exported
    first = frames[0]
    assert len(first.lane) == len(synthetic_map().lanes) == 5
    assert all(len(f.lane) == 0 for f in frames[1:])  # static: the first frame only
    boundaries = {b.id.value: b for b in first.lane_boundary}
    assert len(boundaries) == 2 * len(first.lane)
    for lane in first.lane:
        c = lane.classification
        assert len(c.centerline) >= 2 and c.centerline_is_driving_direction
        assert c.left_lane_boundary_id[0].value in boundaries
        assert c.right_lane_boundary_id[0].value in boundaries
    x0 = next(lane for lane in first.lane if lane.classification.centerline[0].x == -100.0)
    left = boundaries[x0.classification.left_lane_boundary_id[0].value]
    right = boundaries[x0.classification.right_lane_boundary_id[0].value]
    assert [p.position.y for p in left.boundary_line] == pytest.approx([0.0, 0.0])
    assert [p.position.y for p in right.boundary_line] == pytest.approx([-3.5, -3.5])


def test_signal_bulbs_follow_the_recorded_states(exported) -> None:
    # SUMO signal states: G/g green, y amber, r red (SUMO "Traffic Lights", signal state
    # definitions); OSI: one TrafficLight per bulb, lit = MODE_CONSTANT, dark = MODE_OFF.
    _, _, frames = exported
    colors = betterosi.TrafficLightClassificationColor
    lit_of = {"G": colors.GREEN, "y": colors.YELLOW, "r": colors.RED}
    checked = set()
    for frame in frames:
        t = seconds(frame)
        recorded_at = math.floor(t)  # lights were written once a second
        state = light_state(0, recorded_at).lights[0].state
        bulbs = frame.traffic_light
        assert len(bulbs) == 3 * len(state)  # one head of three per link
        for bulb in bulbs:
            link = int(bulb.source_reference[0].identifier[1])
            on = bulb.classification.mode == betterosi.TrafficLightClassificationMode.CONSTANT
            assert on == (bulb.classification.color == lit_of[state[link]]), (t, link)
        checked.add(state)
    assert len(checked) == 3 and SECONDS > 2 * LIGHT_CYCLE_S


def test_the_file_is_an_osi_trace_by_the_spec(exported) -> None:
    _, trace, frames = exported
    with trace.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        meta = {r.name: r.metadata for r in reader.iter_metadata()}
    assert summary is not None and summary.chunk_indexes, "an indexed file with chunks"
    (schema,) = summary.schemas.values()
    assert (schema.name, schema.encoding) == ("osi3.GroundTruth", "protobuf")
    (channel,) = summary.channels.values()
    assert channel.message_encoding == "protobuf"
    assert channel.metadata["net.asam.osi.trace.channel.osi_version"] == "3.8.0"
    assert "net.asam.osi.trace.channel.protobuf_version" in channel.metadata
    trace_meta = meta["net.asam.osi.trace"]
    for key in ("version", "min_osi_version", "max_osi_version",
                "min_protobuf_version", "max_protobuf_version"):  # fmt: skip
        assert trace_meta[key], key
    # the ASAM reader (osi-utilities) opens it as an OSI GroundTruth channel
    from osi_utilities import ChannelSpecification, open_channel

    with open_channel(ChannelSpecification(path=trace, topic="ground_truth")) as channel_reader:
        read = list(channel_reader)
    assert len(read) == len(frames)
    assert type(read[0]).__name__ == "GroundTruth" and read[0].lane
    # and osi-python's own trace reader
    from osi3trace.osi_trace import OSITrace

    official = list(OSITrace(str(trace), "GroundTruth", topic="ground_truth"))
    assert [g.SerializeToString() for g in official] == [g.SerializeToString() for g in read]


def test_user_errors_are_one_line(exported, tmp_path: Path, capsys) -> None:
    recording, _, _ = exported
    assert main(["osi", str(tmp_path / "none.mcap")]) == 2
    assert main(["osi", str(recording), "-o", str(recording)]) == 2
    assert main(["osi", str(recording), "-o", str(tmp_path / "o.mcap"), "--osi-rate", "0"]) == 2
    assert main(["osi", str(recording), "-o", str(tmp_path / "o.osi")]) == 2
    assert main(["osi", str(recording), "-o", str(tmp_path / "o.mcap"), "--osi-host", "x"]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 5 and all(line.startswith("carlaverse osi: ") for line in lines), lines
    assert "ends in .mcap" in lines[3]
    assert "no such ego" in lines[4] and "ego-0, ego-1" in lines[4]


def test_a_leaning_rider_s_box_centre_leans_with_it(tmp_path: Path) -> None:
    # docs/protocol.md: roll positive puts the right side down, so a bike leaning into a left
    # turn sends roll < 0; pitch positive puts the nose down. OSI places the box centre half
    # its height up the body's z axis: a rider leaning left by 0.3 rad, heading north (yaw
    # pi/2, so left is -x), has it h/2 sin 0.3 towards -x and h/2 cos 0.3 up.
    path = tmp_path / "lean.mcap"
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    for k in range(3):
        pose = m.Pose(k, k * 0.05, 10.0, 20.0, 0.0, -0.3, 0.0, math.pi / 2, vy=5.0)
        sink.write(keys.pose("bike-1", "t0_0"), m.POSE.encode(pose), T0_NS + k * 50_000_000)
    sink.write(
        keys.world("events"),
        m.WORLD_EVENT.encode(m.Spawned(1, 0.0, "bike-1", "bike", "bicycle")),
        T0_NS,
    )
    sink.close()
    assert main(["osi", str(path), "-o", str(tmp_path / "lean.osi.mcap")]) == 0
    frame = next(betterosi.read(str(tmp_path / "lean.osi.mcap"), return_ground_truth=True))
    (obj,) = frame.moving_object
    h = m.KIND_EXTENTS["bicycle"].height
    p, o = obj.base.position, obj.base.orientation
    assert (p.x, p.y, p.z) == pytest.approx(
        (10.0 - h / 2 * math.sin(0.3), 20.0, h / 2 * math.cos(0.3)), abs=1e-6
    )
    assert (o.roll, o.yaw) == pytest.approx((-0.3, math.pi / 2), abs=1e-6)


def test_orientation_rate_is_the_rate_of_osi_s_angles(tmp_path: Path) -> None:
    # A pose carries its angular velocity in the world frame (docs/protocol.md); OSI's
    # orientation_rate is the rate of its z-y'-x'' angles. The expected rates come from scipy:
    # turn the pose's rotation by omega * dt in the world frame and difference the angles.
    from scipy.spatial.transform import Rotation

    roll, pitch, yaw, omega = -0.3, 0.1, 2.0, np.array([0.2, -0.1, 0.5])
    path = tmp_path / "spin.mcap"
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    for k in range(2):
        pose = m.Pose(k, k * 0.05, 0.0, 0.0, 0.0, roll, pitch, yaw, 0.0, 0.0, 0.0, *omega)
        sink.write(keys.pose("bike-1", "t0_0"), m.POSE.encode(pose), T0_NS + k * 50_000_000)
    sink.close()
    assert main(["osi", str(path), "-o", str(tmp_path / "spin.osi.mcap")]) == 0
    rate = next(betterosi.read(str(tmp_path / "spin.osi.mcap"), return_ground_truth=True))
    rate = rate.moving_object[0].base.orientation_rate
    dt = 1e-6
    now = Rotation.from_euler("ZYX", [yaw, pitch, roll])
    later = Rotation.from_rotvec(omega.astype(np.float16).astype(float) * dt) * now
    yaw1, pitch1, roll1 = later.as_euler("ZYX")
    expected = ((roll1 - roll) / dt, (pitch1 - pitch) / dt, (yaw1 - yaw) / dt)
    assert (rate.roll, rate.pitch, rate.yaw) == pytest.approx(expected, abs=1e-4)
    assert abs(rate.roll - omega[0]) > 0.01  # not the angular velocity copied through


def test_lanes_of_one_road_are_neighbours_with_the_change_rules_as_markings() -> None:
    # SUMO numbers an edge's lanes from the right (index 0 the rightmost: SUMO "Networks/SUMO
    # Road Networks", lane indices), so E_1 is left of E_0. A lane change allowed across a
    # boundary is a dashed line, one forbidden a solid line; the road's outer edges are not
    # known (the map carries no markings). ":J_0_0" is a SUMO junction-internal lane.
    from carlaverse.recording.osi_map import Lane, LaneBoundary, OsiIds, lanes

    line = [(0.0, 0.0), (50.0, 0.0)]
    road = m.MapReply(2, "two-lane", (0, -10, 60, 10), [
        m.MapLane("E_0", "road", 3.2, line, change_left=True, successors=[":J_0_0"]),
        m.MapLane("E_1", "road", 3.2, [(0.0, 3.2), (50.0, 3.2)], change_right=False),
        m.MapLane(":J_0_0", "road", 3.2, [(50.0, 0.0), (55.0, 0.0)]),
        m.MapLane("E_2", "sidewalk", 2.0, [(0.0, 5.8), (50.0, 5.8)]),
    ])  # fmt: skip
    ids = OsiIds()
    out, boundaries = lanes(road, ids)
    by_id = {lane.id.value: lane for lane in out}
    e0, e1, junction, walk = (by_id[ids.of("lane", n)] for n in ("E_0", "E_1", ":J_0_0", "E_2"))
    assert [a.value for a in e0.classification.left_adjacent_lane_id] == [e1.id.value]
    assert [a.value for a in e1.classification.right_adjacent_lane_id] == [e0.id.value]
    assert not e1.classification.left_adjacent_lane_id  # the sidewalk is no driving neighbour
    assert e0.classification.lane_pairing[0].successor_lane_id.value == junction.id.value
    types = Lane.Classification
    assert (junction.classification.type, walk.classification.subtype) == (
        types.TYPE_INTERSECTION, types.SUBTYPE_SIDEWALK)  # fmt: skip
    marking = {b.id.value: b.classification.type for b in boundaries}
    line_types = LaneBoundary.Classification
    assert marking[e0.classification.left_lane_boundary_id[0].value] == line_types.TYPE_DASHED_LINE
    assert marking[e1.classification.right_lane_boundary_id[0].value] == line_types.TYPE_SOLID_LINE
    assert marking[e0.classification.right_lane_boundary_id[0].value] == line_types.TYPE_UNKNOWN


def test_vehicle_lights_follow_the_recorded_bits(exported) -> None:
    # docs/protocol.md light bits; OSI LightState: a blinker is INDICATOR_STATE_LEFT/RIGHT,
    # both at once the hazard WARNING; low beams are the head lights, and they and the
    # position (parking) lights light the tail lights; brake lights NORMAL when braking.
    _, _, frames = exported
    indicator, generic = (
        betterosi.MovingObjectVehicleClassificationLightStateIndicatorState,
        betterosi.MovingObjectVehicleClassificationLightStateGenericLightState,
    )
    brake = betterosi.MovingObjectVehicleClassificationLightStateBrakeLightState
    seen = set()
    for frame in frames:
        t = seconds(frame)
        objects = {actor_of(o): o for o in frame.moving_object}
        ego, npc = (objects[a].vehicle_classification.light_state for a in ("ego-0", "npc-0"))
        if t < 2.0:
            assert ego is None, t  # nothing recorded yet: no light state
        elif t < 5.0:
            assert (ego.indicator_state, ego.head_light, ego.tail_light) == (
                indicator.LEFT, generic.ON, generic.ON), t  # fmt: skip
        else:
            assert (ego.indicator_state, ego.head_light, ego.tail_light) == (
                indicator.WARNING, generic.OFF, generic.ON), t  # fmt: skip
        want = (indicator.RIGHT, brake.NORMAL) if t >= 3.0 else (indicator.OFF, brake.OFF)
        assert (npc.indicator_state, npc.brake_light_state) == want, t
        seen.add((ego and ego.indicator_state, want))
    assert len(seen) == 4  # before any state, left, left and braking NPC, hazard


def test_map_every_frame_and_another_host(exported, tmp_path: Path) -> None:
    recording, _, _ = exported
    out = tmp_path / "every.osi.mcap"
    argv = ["osi", str(recording), "-o", str(out), "--osi-map-every-frame", "--osi-host", "ego-1"]
    assert main(argv) == 0
    frames = list(betterosi.read(str(out), return_ground_truth=True))
    assert all(len(f.lane) == 5 and len(f.lane_boundary) == 10 for f in frames)
    ego1 = {actor_of(o): o.id.value for o in frames[0].moving_object}["ego-1"]
    assert {f.host_vehicle_id.value for f in frames} == {ego1}


def test_record_recover_osi_exports_the_recovered_file(exported, tmp_path: Path) -> None:
    recording, _, frames = exported
    out = tmp_path / "clean.mcap"
    argv = ["record", "--recover", str(recording), "-o", str(out), "--osi", "--osi-rate", "20"]
    assert main(argv) == 0
    again = list(betterosi.read(str(tmp_path / "clean.osi.mcap"), return_ground_truth=True))
    assert len(again) == len(frames)
    assert [len(f.moving_object) for f in again] == [len(f.moving_object) for f in frames]


def test_an_acceleration_not_sent_is_the_recorded_velocity_s_derivative(tmp_path: Path) -> None:
    # A scripted rider brakes from 10 m/s at 2 m/s² heading north-east and sends no
    # acceleration: OSI gets dv/dt = 2 m/s² against its velocity, (-sqrt 2, -sqrt 2).
    path = tmp_path / "brake.mcap"
    keys = Keys("rec")
    sink = McapSink(path, monotonic=time.monotonic)
    c = math.sqrt(0.5)
    for k in range(26):  # 20 Hz for 1.25 s
        t = k * 0.05
        speed = 10.0 - 2.0 * t
        pose = m.Pose(k, t, 0.0, 0.0, yaw=math.pi / 4, vx=c * speed, vy=c * speed)
        sink.write(keys.pose("bike-1", "t0_0"), m.POSE.encode(pose), T0_NS + round(t * 1e9))
    sink.close()
    assert main(["osi", str(path), "-o", str(tmp_path / "brake.osi.mcap")]) == 0
    frames = list(betterosi.read(str(tmp_path / "brake.osi.mcap"), return_ground_truth=True))
    assert len(frames) == 26
    for frame in frames:
        a = frame.moving_object[0].base.acceleration
        assert (a.x, a.y) == pytest.approx((-2 * c, -2 * c), abs=1e-4)


def test_the_weather_in_osi_s_angles_and_categories(exported) -> None:
    # osi_environment.proto: Sun.azimuth and Wind.origin_direction count counter-clockwise
    # from north ("0: north; +pi/2: west; pi: south, 3/2 pi: east"), so a sun due east is
    # 3/2 pi and a wind from the west pi/2. README: rain 10 mm/h is 1.0, so 0.3 is 3 mm/h,
    # MODERATE in OSI's [1.9, 8.1[ mm/h; fog density 1 - visibility / 1000 m, so 0.9 is
    # 100 m, THICK in [50, 200[ m; cloudiness 0.5 is four oktas of eight.
    _, _, frames = exported
    env = frames[5].environmental_conditions
    assert env.sun.azimuth == pytest.approx(1.5 * math.pi)
    assert env.sun.elevation == pytest.approx(math.radians(30))
    assert (env.wind.origin_direction, env.wind.speed) == pytest.approx((0.5 * math.pi, 4.0))
    assert env.precipitation == betterosi.EnvironmentalConditionsPrecipitation.MODERATE
    assert env.fog == betterosi.EnvironmentalConditionsFog.THICK
    oktas = betterosi.EnvironmentalConditionsCloudLayerFractionalCloudCover
    assert env.clouds.fractional_cloud_cover == oktas.FOUR_OKTAS
