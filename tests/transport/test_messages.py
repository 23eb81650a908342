from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse import messages as m

POSE = m.Pose(
    7,
    1234.5,
    1.5,
    -2.25,
    0.5,
    0.015625,
    -0.03125,
    3.0,
    14.0,
    -1.0,
    0.125,
    0.0,
    0.0,
    0.25,
    1.0,
    -0.5,
    0.0,
    m.POSE_FLAG_TELEPORT,
)


def examples() -> list[tuple[m.Codec, object]]:
    batch = m.NpcBatch.pack(3, 9.0, ["v1", "p1"], np.zeros(2, dtype=m.NPC_DTYPE))
    lights = m.LightsState(1, 2.0, [m.TrafficLight("J1", "GGrr", 0, 12.5)])
    weather = m.Weather(1, 2.0, cloudiness=0.4)
    return [
        (m.POSE, POSE),
        (m.EGO_STATE, m.EgoState(1, 2.0, m.LIGHT_LOW_BEAM, "left", 3, 12.0, "acc")),
        (m.OVERRIDE, m.Override(1, 2.0, "acc", cruise_speed_mps=13.9)),
        (m.SKELETON, m.Skeleton(1, 2.0, ["hip"], b"\x00" * 12)),
        (m.NPC_BATCH, batch),
        (m.POSE_DIGEST, m.PoseDigest(5, ["a", "b"], m.encode_pose(POSE) * 2)),
        (m.LIGHTS, lights),
        (m.WEATHER, weather),
        (m.WORLD_EVENT, m.Spawned(1, 2.0, "n", "drive")),
        (m.WORLD_EVENT, m.Despawned(2, 2.0, "n", "timeout")),
        (m.WORLD_EVENT, m.ContactStarted(3, 2.0, 9, "n", "v1", 3.5)),
        (m.WORLD_EVENT, m.ContactEnded(4, 2.0, 9, "n", "v1")),
        (m.IMPULSE, m.Impulse(1, 2.0, 9, (1.0, 0, 0), (0, 0, 0.5), (1.0, 0, 0), "v1", "car", 3.0)),
        (
            m.AUDIO_SCENE,
            m.AudioScene(
                1,
                2.0,
                "n",
                [m.AudioEmitter("v1.engine", "engine", 1, 2, 0, 3, 0, 0, 80.0, 0.0, 2400.0, 0.5)],
            ),
        ),
        (
            m.JOIN_REQUEST,
            m.JoinRequest(m.SCHEMA_VERSION, "n", "abc", "drive", config_yaml="a: 1\n"),
        ),
        (m.JOIN_REPLY, m.JoinReply(m.SCHEMA_VERSION, True, spawn=m.SpawnPoint(1, 2, 0, 0.5))),
        (m.LEAVE_REQUEST, m.LeaveRequest("n", "abc")),
        (m.LEAVE_REPLY, m.LeaveReply(True)),
        (m.CLOCK_REQUEST, m.ClockRequest("n")),
        (m.CLOCK_REPLY, m.ClockReply(1.5, True)),
        (
            m.SNAPSHOT,
            m.Snapshot(
                m.SCHEMA_VERSION,
                1.0,
                [m.EgoInfo("n", "drive", "car", m.Extent(), 1500.0, pose_wire=m.encode_pose(POSE))],
                batch,
                lights,
                weather,
            ),
        ),
        (
            m.MAP,
            m.MapReply(
                m.SCHEMA_VERSION,
                "town",
                (0, 0, 1, 1),
                [m.MapLane("e_0", "road", 3.2, [(0, 0), (1, 0)])],
            ),
        ),
        (m.SCENARIO, m.ScenarioReply(m.SCHEMA_VERSION, "town", "map: {}\n", 42)),
        (m.CONFIGS, m.ConfigsReply(m.SCHEMA_VERSION, {"n": "a: 1\n"}, "map: {}\n", {"n": "h"})),
        (
            m.QUESTIONNAIRE_REQUEST,
            m.QuestionnaireRequest(
                m.SCHEMA_VERSION,
                "t1.q",
                "t1",
                "q",
                "Q",
                [
                    m.QuestionnaireItem("a", "How?", "scale", 0, 100, 5, ["low", "high"]),
                    m.QuestionnaireItem("b", "Which?", "choice", labels=["x", "y"]),
                    m.QuestionnaireItem("c", "Else?", "text", required=False, max_chars=80),
                ],
            ),
        ),
        (
            m.QUESTIONNAIRE_ANSWERS,
            m.QuestionnaireAnswers(m.SCHEMA_VERSION, "t1.q", "n", 2, {"a": 55, "c": "no"}, True),
        ),
        (m.TRIAL_BRIEF, m.TrialBrief(m.SCHEMA_VERSION, "lab", "p01", True, "t1", 1, "lab-t1")),
    ]


@pytest.mark.parametrize("codec,msg", examples(), ids=lambda v: type(v).__name__)
def test_every_message_round_trips(codec: m.Codec, msg: object) -> None:
    assert codec.decode(codec.encode(msg)) == msg


def test_every_channel_and_request_type_has_an_example() -> None:
    covered = {id(codec) for codec, _ in examples()}
    codecs = [*m.CHANNEL_CODECS.values(), *m.REQUEST_CODECS.values()]
    assert all(id(codec) in covered for codec in codecs)


def test_the_snapshot_carries_poses_in_the_one_pose_layout() -> None:
    info = m.EgoInfo("n", "drive", "car", m.Extent(), 1500.0, "lab", POSE)  # a Pose is encoded
    wire = msgspec.msgpack.decode(m.SNAPSHOT.encode(m.Snapshot(m.SCHEMA_VERSION, 1.0, [info])))
    assert wire["egos"][0]["pose"] == m.encode_pose(POSE)  # 64 bytes, the `ego/*/pose` layout
    assert m.SNAPSHOT.decode(m.SNAPSHOT.encode(m.Snapshot(2, 1.0, [info]))).egos[0].pose == (
        m.decode_pose(m.encode_pose(POSE))
    )


def test_pose_fits_in_64_bytes_with_float32_precision() -> None:
    wire = m.encode_pose(POSE)
    assert len(wire) == m.POSE_SIZE <= 64
    back = m.decode_pose(wire)
    assert back.t == POSE.t  # time stays float64
    assert math.isclose(back.x, POSE.x) and math.isclose(back.wz, POSE.wz, rel_tol=1e-3)
    # float32 keeps a millimetre at 10 km from the origin
    far = m.decode_pose(m.encode_pose(m.Pose(1, 0.0, 10_000.123, -9_999.877)))
    assert abs(far.x - 10_000.123) < 1e-3 and abs(far.y + 9_999.877) < 1e-3


def test_pose_with_nan_is_refused() -> None:
    with pytest.raises(m.MessageError, match="non-finite"):
        m.decode_pose(m.encode_pose(m.Pose(1, 0.0, float("nan"), 0.0)))


@given(st.binary(max_size=300))
def test_decoders_raise_only_message_error(data: bytes) -> None:
    for codec in {id(c): c for c in m.CHANNEL_CODECS.values()}.values():
        try:
            codec.decode(data)
        except m.MessageError:
            pass


def test_npc_batch_rows_are_structured_arrays() -> None:
    rows = np.zeros(3, dtype=m.NPC_DTYPE)
    rows["x"] = [1, 2, 3]
    batch = m.NPC_BATCH.decode(m.NPC_BATCH.encode(m.NpcBatch.pack(1, 0.0, ["a", "b", "c"], rows)))
    assert list(batch.array()["x"]) == [1, 2, 3]


@pytest.mark.parametrize(
    "kind,drive_a,drive_b",
    [("engine", 2400.0, 1.5), ("tyres", -1.0, 0.0), ("siren", 0.5, 0.0), ("siren", 9.0, 0.0),
     ("rain", 1.2, 0.0), ("wind", 0.5, 3.0)],
)  # fmt: skip
def test_audio_drive_values_outside_their_kinds_range_are_refused(
    kind: str, drive_a: float, drive_b: float
) -> None:
    emitter = m.AudioEmitter("s", kind, 0, 0, 0, 0, 0, 0, 70.0, drive_a=drive_a, drive_b=drive_b)
    with pytest.raises(m.MessageError, match="audio emitter 's'"):
        m.AUDIO_SCENE.decode(m.AUDIO_SCENE.encode(m.AudioScene(1, 0.0, "n", [emitter])))


def test_audio_scene_refuses_an_unknown_kind_and_too_many_emitters() -> None:
    horn = ["s", "horn", 0, 0, 0, 0, 0, 0, 70.0]
    wire = msgspec.msgpack.encode({"seq": 1, "t": 0.0, "listener": "n", "emitters": [horn]})
    with pytest.raises(m.MessageError, match="horn"):
        m.AUDIO_SCENE.decode(wire)
    many = [m.AudioEmitter(f"s{i}", "rain", 0, 0, 0, 0, 0, 0, 60.0) for i in range(257)]
    with pytest.raises(m.MessageError, match="at most 256"):
        m.AUDIO_SCENE.decode(m.AUDIO_SCENE.encode(m.AudioScene(1, 0.0, "n", many)))
