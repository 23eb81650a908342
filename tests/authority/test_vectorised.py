"""The authority's per-tick work over all egos at once equals the per-ego rules it replaced.

Each reference below is the per-actor code the tick ran before it was vectorised, kept here
as the definition (for dead reckoning, the scalar form of the one motion model); random
rosters and payloads must give the same result.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.authority.actors import EgoColumns, EgoNow, build_actors, egos_at, has_actor
from carlaverse.authority.domain import EgoTrack
from carlaverse.authority.pose_intake import PoseIntake
from carlaverse.authority.sound_audibility import audible, emitters
from carlaverse.authority.sound_sources import EVERY_LISTENER, SoundSources, actor_columns
from carlaverse.dead_reckoning import project
from carlaverse.messages import ACTOR_KINDS, AUDIO_KINDS, NPC_DTYPE, EgoInfo, Extent, Pose
from carlaverse.support.angles import wrap_angle
from carlaverse.support.tally import Tally
from carlaverse.traffic.engine import EgoPlacements, NpcFrame, kind_code
from carlaverse.traffic.scenario import CollisionSpec

MAX_EXTRAPOLATION_S = 0.5  # [s]


# ------------------------------------------------------------------ the per-ego references


def egos_at_one_by_one(t: float, egos: dict[str, EgoTrack]) -> list[EgoNow]:
    """Each ego's last pose moved on by the scalar form of the one motion model."""
    out = []
    for node_id in sorted(egos):
        track = egos[node_id]
        pose = track.last_pose
        if pose is None or not has_actor(track):
            continue
        p = project(pose, min(max(t - pose.t, 0.0), MAX_EXTRAPOLATION_S))
        e = track.info.extent
        out.append(EgoNow(node_id, track.info.actor_kind, p.x, p.y, p.z, p.yaw, p.vx, p.vy,
                          e.length, e.width, e.height, track.info.mass_kg))  # fmt: skip
    return out


def decode_one_by_one(payload: bytes) -> Pose | None:
    try:
        return m.decode_pose(payload)
    except m.MessageError:
        return None


# ------------------------------------------------------------------ random inputs


def random_roster(rng: np.random.Generator, n: int, t: float) -> dict[str, EgoTrack]:
    kinds = [*ACTOR_KINDS, "", "zeppelin"]
    tracks = {}
    for i in rng.permutation(n):
        node_id = f"ego-{i}"
        kind, actor_kind = rng.choice(["drive", "observer", "bike"]), rng.choice(kinds)
        extent, mass_kg = Extent(*rng.uniform(0.3, 12.0, 3)), rng.choice([0.0, 900.0])
        info = EgoInfo(node_id, str(kind), str(actor_kind), extent, float(mass_kg))
        track = EgoTrack(info, "x", 0.0)
        if rng.random() < 0.9:
            v = rng.normal(0, 300, 16)
            track.last_pose = Pose(i, t - rng.uniform(-0.1, 2.0), *v)
        tracks[node_id] = track
    return tracks


def random_frame(rng: np.random.Generator, n: int) -> NpcFrame:
    rows = np.zeros(n, dtype=NPC_DTYPE)
    for name in ("x", "y", "z", "yaw", "vx", "vy", "length", "width", "height"):
        rows[name] = rng.uniform(0.5, 50.0, n)
    rows["kind"] = rng.integers(0, len(ACTOR_KINDS), n)
    return NpcFrame(0.0, [f"npc{i}" for i in range(n)], rows)


@pytest.mark.parametrize("seed", range(8))
def test_egos_at_equals_the_per_ego_dead_reckoning(seed: int) -> None:
    rng = np.random.default_rng(seed)
    roster = random_roster(rng, int(rng.integers(0, 40)), t=100.0)
    fast = list(egos_at(100.0, roster, MAX_EXTRAPOLATION_S))
    slow = egos_at_one_by_one(100.0, roster)
    assert [(e.node_id, e.actor_kind) for e in fast] == [(e.node_id, e.actor_kind) for e in slow]
    for got, want in zip(fast, slow, strict=True):
        # numpy's and libm's sin may differ in the last bit; yaw is compared on the circle
        assert wrap_angle(got.yaw - want.yaw) == pytest.approx(0.0, abs=1e-9)
        fields = ("x", "y", "z", "vx", "vy", "length", "width", "height", "mass_kg")
        assert np.allclose([getattr(got, f) for f in fields], [getattr(want, f) for f in fields],
                           rtol=1e-9, atol=1e-9)  # fmt: skip


@pytest.mark.parametrize("seed", range(8))
def test_placements_equal_each_egos_placement(seed: int) -> None:
    rng = np.random.default_rng(seed)
    now = egos_at(50.0, random_roster(rng, 30, t=50.0), MAX_EXTRAPOLATION_S)
    for got, want in zip(now.placements(), (e.placement() for e in now), strict=True):
        assert got.node_id == want.node_id and got.actor_kind == want.actor_kind
        # numpy's and libm's cos/sin may differ in the last bit: 1e-12 relative, no more.
        assert np.allclose(_fields(got), _fields(want), rtol=1e-12, atol=0)


def _fields(p: object) -> list[float]:
    return [getattr(p, f) for f in ("x", "y", "z", "yaw", "speed", "length", "width", "height")]


@pytest.mark.parametrize("seed", range(6))
def test_actor_tables_equal_the_per_ego_tables(seed: int) -> None:
    rng = np.random.default_rng(seed)
    now = egos_at(10.0, random_roster(rng, 25, t=10.0), MAX_EXTRAPOLATION_S)
    one_by_one = list(now)
    frame = random_frame(rng, int(rng.integers(0, 60)))
    spec = CollisionSpec()
    fast, slow = build_actors(now, frame, spec), build_actors_one_by_one(one_by_one, frame, spec)
    assert fast.ids == slow.ids
    for name in ("kind", "is_ego", "x", "y", "z", "yaw", "hl", "hw", "h", "vx", "vy", "mass",
                 "restitution"):  # fmt: skip
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    heard, ref = actor_columns(now, frame), actor_columns(EgoColumns.of(one_by_one), frame)
    assert heard.ids == ref.ids and np.array_equal(heard.kind, ref.kind)
    ego_pos = np.array([(e.x, e.y, e.z) for e in one_by_one]).reshape(-1, 3)
    assert np.array_equal(heard.pos[: len(now)], ego_pos)


def build_actors_one_by_one(egos: list[EgoNow], frame: NpcFrame, spec: CollisionSpec):  # type: ignore[no-untyped-def]
    """The collision table as it was built: a Python list per column over the egos."""
    from carlaverse.authority.collisions import Actors

    rows = frame.rows
    mass_of = np.array([spec.physics(k).mass_kg for k in ACTOR_KINDS])
    bounce_of = np.array([spec.physics(k).restitution for k in ACTOR_KINDS])
    ego_kind = np.array([kind_code(e.actor_kind) for e in egos], dtype=np.intp)
    kind = np.concatenate([ego_kind, rows["kind"].astype(np.intp)])
    ego_mass = np.array([e.mass_kg for e in egos], dtype=np.float64)
    ego_mass = np.where(ego_mass > 0, ego_mass, mass_of[ego_kind])

    def column(attr: str, npc: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [np.array([getattr(e, attr) for e in egos], dtype=np.float64), npc.astype(np.float64)]
        )

    return Actors(
        ids=[e.node_id for e in egos] + frame.ids, kind=kind,
        is_ego=np.arange(len(kind)) < len(egos), x=column("x", rows["x"]),
        y=column("y", rows["y"]), z=column("z", rows["z"]), yaw=column("yaw", rows["yaw"]),
        hl=column("length", rows["length"]) / 2, hw=column("width", rows["width"]) / 2,
        h=column("height", rows["height"]), vx=column("vx", rows["vx"]),
        vy=column("vy", rows["vy"]), mass=np.concatenate([ego_mass, mass_of[kind[len(egos):]]]),
        restitution=bounce_of[kind],
    )  # fmt: skip


def test_ego_columns_read_as_the_egos_they_hold() -> None:
    egos = [EgoNow("a", "car", 1, 2, 3, 0.5, 4, 5, 4.5, 1.8, 1.5, 0.0),
            EgoNow("b", "bicycle", -1, 0, 0, 1.0, 0, 1, 1.8, 0.6, 1.7, 90.0)]  # fmt: skip
    columns = EgoColumns.of(egos)
    assert list(columns) == egos and columns[-1] == egos[1] and len(columns) == 2
    with pytest.raises(IndexError):
        columns[2]
    assert len(EgoColumns.of([])) == 0 and list(EgoColumns.of([]).placements()) == []


def test_placements_cross_to_sumo_s_process_as_the_same_rows() -> None:
    rng = np.random.default_rng(3)
    placements = egos_at(50.0, random_roster(rng, 30, t=50.0), MAX_EXTRAPOLATION_S).placements()
    rows = list(placements)
    back = pickle.loads(pickle.dumps(placements))
    assert list(back) == rows and EgoPlacements.of(rows).ids == placements.ids
    assert list(EgoPlacements.of(rows)) == rows and EgoPlacements.of(placements) is placements
    assert back[-1] == rows[-1] and back[0] == rows[0]
    assert len(rows) > 10  # some of the roster are observers or have no pose yet
    with pytest.raises(IndexError, match=f"placement {len(rows)} of {len(rows)}"):
        back[len(rows)]
    with pytest.raises(ValueError, match="2 ids, 1 kinds"):
        EgoPlacements(["a", "b"], ["car"], np.zeros((2, 8)))
    with pytest.raises(ValueError, match=r"shape \(2, 7\)"):
        EgoPlacements(["a", "b"], ["car", "car"], np.zeros((2, 7)))


# ------------------------------------------------------------------ pose intake

LAYOUT_FLOATS = 15  # after t: x … vz as f32, wx … az as f16

finite = st.floats(-1e5, 1e5, allow_nan=False, width=32)
odd = st.sampled_from([math.nan, math.inf, -math.inf, 7e4, 1e13])


@st.composite
def payloads(draw: st.DrawFn) -> bytes:
    """Mostly valid poses; some with a bad version, a non-finite value, a wild time or size."""
    values = [draw(st.one_of(finite, odd)) if draw(st.booleans()) and draw(st.booleans())
              else draw(finite) for _ in range(LAYOUT_FLOATS)]  # fmt: skip
    f16 = [v if abs(v) < 6e4 or not math.isfinite(v) else 1.0 for v in values[9:]]
    t = draw(st.one_of(st.floats(-2e12, 2e12, allow_nan=False), odd))
    version = draw(st.sampled_from([m.POSE_LAYOUT_VERSION] * 5 + [0, 2]))
    flags, seq = draw(st.integers(0, 255)), draw(st.integers(0, 2**32 - 1))
    packed = m.POSE_LAYOUT.pack(version, flags, 0, seq, t, *values[:9], *f16)
    cut = draw(st.sampled_from([None] * 8 + [0, 63, 65]))
    return packed if cut is None else (packed + b"\0")[:cut]


@given(st.lists(payloads(), max_size=30))
@settings(max_examples=150, deadline=None)
def test_batch_decode_equals_decode_pose(batch: list[bytes]) -> None:
    samples = [FakeSample(f"carlaverse/s/ego/e{i}/pose", p) for i, p in enumerate(batch)]
    drops = Tally()
    taken = PoseIntake(FakeRing(samples), drops).drain()
    one_by_one = [(f"e{i}", decode_one_by_one(p)) for i, p in enumerate(batch)]
    expected = [(node_id, pose) for node_id, pose in one_by_one if pose is not None]
    assert taken == expected
    assert drops["pose"] == len(batch) - len(expected)


class Payload(bytes):
    def to_bytes(self) -> bytes:
        return bytes(self)


class FakeSample:
    """A `zenoh.Sample` as the intake reads it: the key and the payload's bytes."""

    def __init__(self, key: str, payload: bytes) -> None:
        self.key_expr, self.payload = key, Payload(payload)


class FakeRing:
    """Zenoh's ring handler as the intake sees it: try_recv until None."""

    def __init__(self, samples: list[FakeSample]) -> None:
        self.samples = list(samples)

    def try_recv(self) -> FakeSample | None:
        return self.samples.pop(0) if self.samples else None


def test_intake_counts_every_bad_sample_and_keeps_arrival_order() -> None:
    good = m.encode_pose(Pose(1, 10.0, 1.0, 2.0))
    later = m.encode_pose(Pose(2, 10.02, 1.5, 2.0))
    nan = m.encode_pose(Pose(3, 10.0, math.nan, 0.0))
    samples = [
        FakeSample("carlaverse/s/ego/a/pose/t0_0", good),
        FakeSample("carlaverse/s/ego/b/pose", good[:-1]),  # short
        FakeSample("carlaverse/s/ego/c/pose", nan),  # non-finite
        FakeSample("not/a/key", good),  # foreign key
        FakeSample("carlaverse/s/world/npc", good),  # not a pose key
        FakeSample("carlaverse/s/ego/a/pose/t0_0", later),
    ]
    drops = Tally()
    taken = PoseIntake(FakeRing(samples), drops).drain()
    assert [(n, p.seq) for n, p in taken] == [("a", 1), ("a", 2)]
    assert drops["pose"] == 4


def test_intake_takes_at_most_its_limit_per_drain() -> None:
    pose = m.encode_pose(Pose(1, 1.0, 0.0, 0.0))
    ring = FakeRing([FakeSample(f"carlaverse/s/ego/e{i}/pose", pose) for i in range(5)])
    intake = PoseIntake(ring, Tally())
    assert len(intake.drain(limit=3)) == 3 and len(intake.drain()) == 2 and intake.drain() == []


def test_while_the_digest_relays_the_tick_takes_its_rows_and_leaves_the_ring_alone() -> None:
    def sample(node_id: str, seq: int) -> FakeSample:
        return FakeSample(f"carlaverse/s/ego/{node_id}/pose", m.encode_pose(Pose(seq, 1.0, 0, 0)))

    ring = FakeRing([sample("a", 1), FakeSample("carlaverse/s/ego/b/pose", b"short")])
    drops = Tally()
    intake = PoseIntake(ring, drops)
    intake.relayed = True
    assert intake.drain() == [] and len(ring.samples) == 2  # the ring is the relay's now
    ids, rows = intake.relay_take()
    assert ids == ["a"] and len(rows) == 1 and drops["pose"] == 1  # counted once, here
    ring.samples.append(sample("c", 2))
    assert [(n, p.seq) for n, p in intake.drain()] == [("a", 1)]  # what the relay took
    assert len(ring.samples) == 1
    intake.relayed = False  # nobody hears the digest: the tick drains the ring again
    assert [(n, p.seq) for n, p in intake.drain()] == [("c", 2)]
    assert drops["pose"] == 1


# ------------------------------------------------------------------ audio


def random_sources(rng: np.random.Generator, n: int, listeners: int | None) -> SoundSources:
    """`n` sources; with `listeners`, each row is for one of them (areas, rain)."""
    return SoundSources.build(
        [f"s{i}" for i in range(n)],
        rng.integers(0, len(AUDIO_KINDS), n),
        rng.uniform(-300, 300, (n, 3)),
        rng.uniform(40, 100, n),
        rng.uniform(0, 10, (n, 2)),
        owner=rng.integers(-1, 5, n),
        listener=rng.integers(0, listeners, n) if listeners else EVERY_LISTENER,
        vel=rng.normal(0, 5, (n, 3)),
    )


@pytest.mark.parametrize("seed", range(6))
def test_shared_emitters_equal_one_emitter_per_row(seed: int) -> None:
    rng = np.random.default_rng(seed)
    listeners = int(rng.integers(1, 12))
    ears = rng.uniform(-300, 300, (listeners, 3))
    shared = random_sources(rng, int(rng.integers(0, 80)), None)
    own = random_sources(rng, int(rng.integers(0, 20)), listeners)
    heard = audible(ears, shared, own, threshold_db=30.0, cap=8)
    assert len(heard.rows) > 0 or len(shared) + len(own) == 0
    assert heard.emitters() == emitters(heard.sources)
