"""The one motion model (`carlaverse.dead_reckoning`) against physics, and its users against it.

Every expected position below is derived here from the motion itself (a circle, a straight
line, a kinematic ODE integrated numerically), never from the module's formulas. The last
tests follow one ego through the authority's collision check (`egos_at`) and a remote node's
world view, both fed the same wire bytes: the two must put it at the same place.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from carlaverse.authority.actors import egos_at
from carlaverse.authority.domain import EgoTrack
from carlaverse.dead_reckoning import Motion, npc_motion, project, project_many
from carlaverse.messages import Pose
from carlaverse.support.angles import wrap_angle
from carlaverse.traffic.engine import NpcFrame
from carlaverse.world.npc_table import NpcTable
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView

FIELDS = ("x", "y", "z", "vx", "vy", "vz")


def one(value: object) -> float:
    """A field of `project` (a float) or of `project_many` over one actor (an array)."""
    return float(np.ravel(value)[0])  # type: ignore[call-overload]


def columns(poses: list[Pose]) -> Motion:
    """The poses as the array form takes them."""
    return Motion(*(np.array([getattr(p, f) for p in poses], dtype=np.float64)
                    for f in Motion._fields))  # fmt: skip


# ------------------------------------------------------------------ a circle


class Circle:
    """Driving a circle of radius R [m] about (cx, cy) at speed v [m/s]; left turn if left.

    At polar angle φ the position is c + R(cos φ, sin φ); φ grows at ω = ±v/R. Its
    derivatives: velocity Rω(−sin φ, cos φ) (tangent, |v|), acceleration −Rω²(cos φ, sin φ)
    (centripetal, v²/R towards the centre); the heading is φ ± π/2 and turns at ω too.
    """

    def __init__(self, r: float, v: float, left: bool, cx: float = 5.0, cy: float = -3.0):
        self.r, self.cx, self.cy = r, cx, cy
        self.w = v / r if left else -v / r  # [rad/s]
        self.side = math.pi / 2 if left else -math.pi / 2

    def pose(self, t: float, phi0: float) -> Pose:
        phi, r, w = phi0 + self.w * t, self.r, self.w
        c, s = math.cos(phi), math.sin(phi)
        return Pose(0, t, self.cx + r * c, self.cy + r * s, 0.0, 0.0, 0.0,
                    wrap_angle(phi + self.side), -r * w * s, r * w * c, 0.0, 0.0, 0.0, w,
                    -r * w * w * c, -r * w * w * s, 0.0)  # fmt: skip


@pytest.mark.parametrize("left", [True, False], ids=["left", "right"])
@pytest.mark.parametrize("dt", [0.02, 0.25, 0.5, -0.3, 2.0])
def test_a_circle_sample_lands_on_the_circle_at_arc_v_dt(left: bool, dt: float) -> None:
    circle, v, phi0 = Circle(r=20.0, v=14.0, left=left), 14.0, 0.7
    sample, truth = circle.pose(0.0, phi0), circle.pose(dt, phi0)
    for got in (project(sample, dt), project_many(columns([sample]), dt)):
        x, y = one(got.x), one(got.y)
        # on the circle, and the chord from the sample is 2R sin(arc / 2R), arc = v·|dt|
        assert math.hypot(x - circle.cx, y - circle.cy) == pytest.approx(20.0, abs=1e-9)
        chord = 2 * 20.0 * math.sin(v * abs(dt) / (2 * 20.0))
        assert math.hypot(x - sample.x, y - sample.y) == pytest.approx(chord, abs=1e-9)
        assert (x, y) == pytest.approx((truth.x, truth.y), abs=1e-9)  # on the correct side
        assert one(got.vx) == pytest.approx(truth.vx, abs=1e-9)
        assert one(got.vy) == pytest.approx(truth.vy, abs=1e-9)
        yaw = one(got.yaw)
        assert wrap_angle(yaw - truth.yaw) == pytest.approx(0.0, abs=1e-12)
    turned = project(sample, dt)  # and the acceleration still points at the centre
    assert (turned.ax, turned.ay) == pytest.approx((truth.ax, truth.ay), abs=1e-9)


def test_npc_rows_without_acceleration_also_stay_on_their_circle() -> None:
    """An NPC row carries position, heading, velocity and yaw rate only: its (unknown)
    acceleration is the turn's own, so a turning NPC stays on its circle too."""
    circle, dt = Circle(r=12.0, v=8.0, left=True), 0.4
    sample, truth = circle.pose(0.0, 2.0), circle.pose(dt, 2.0)
    rows = np.zeros(1, dtype=m.NPC_DTYPE)
    for name, value in (("x", sample.x), ("y", sample.y), ("yaw", sample.yaw),
                        ("vx", sample.vx), ("vy", sample.vy), ("yaw_rate", sample.wz)):  # fmt: skip
        rows[name] = value
    got = project_many(npc_motion(rows), dt)
    # the rows are float32: ~1e-6 of 20 m
    assert (got.x[0], got.y[0]) == pytest.approx((truth.x, truth.y), abs=1e-4)
    moved = NpcFrame(0.0, ["n"], rows).at(dt).rows[0]  # the traffic engine between steps
    assert (moved["x"], moved["y"]) == pytest.approx((truth.x, truth.y), abs=1e-4)
    table = NpcTable(InterpolationSettings())  # a node's world view past the newest batch
    table.add(m.NpcBatch.pack(0, 0.0, ["n"], rows), 0.0)
    frame = table.frame(dt, 0.5)
    assert frame is not None
    assert (frame.x[0], frame.y[0]) == pytest.approx((truth.x, truth.y), abs=1e-4)


# ------------------------------------------------------------------ a straight line


@pytest.mark.parametrize("dt", [0.1, 0.5, -0.4])
def test_a_straight_line_at_zero_yaw_rate(dt: float) -> None:
    """Heading 30°, 12 m/s, speeding up at 1.5 m/s² along the heading:
    p(dt) = p + v·dt + ½·a·dt², v(dt) = v + a·dt, the heading unchanged."""
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    sample = Pose(0, 0.0, 3.0, 4.0, 1.0, yaw=math.pi / 6, vx=12 * c, vy=12 * s,
                  ax=1.5 * c, ay=1.5 * s)  # fmt: skip
    along = 12 * dt + 0.75 * dt * dt
    for got in (project(sample, dt), project_many(columns([sample]), dt)):
        assert one(got.x) == pytest.approx(3.0 + along * c, abs=1e-12)
        assert one(got.y) == pytest.approx(4.0 + along * s, abs=1e-12)
        assert one(got.z) == 1.0
        assert one(got.vx) == pytest.approx((12 + 1.5 * dt) * c, abs=1e-12)
        assert one(got.yaw) == pytest.approx(math.pi / 6, abs=1e-15)


def test_a_braking_actor_stops_and_one_starting_off_stood_still_before() -> None:
    """Braking from 10 m/s at 5 m/s² stops after v/a = 2 s, v²/2a = 10 m on, and stays there;
    one at 4 m/s speeding up at 2 m/s² set off 2 s ago from 4²/(2·2) = 4 m back."""
    braking = Pose(0, 0.0, 0.0, 0.0, vx=0.0, vy=10.0, ax=0.0, ay=-5.0, yaw=math.pi / 2)
    starting = Pose(0, 0.0, 0.0, 0.0, vx=4.0, ax=2.0)
    for got in (project(braking, 3.0), project_many(columns([braking]), 3.0)):
        assert one(got.y) == pytest.approx(10.0, abs=1e-12)
        assert one(got.vy) == pytest.approx(0.0, abs=1e-12)
    for got in (project(starting, -3.0), project_many(columns([starting]), -3.0)):
        assert one(got.x) == pytest.approx(-4.0, abs=1e-12)
        assert one(got.vx) == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------ turning and accelerating


def integrated(x: float, y: float, heading: float, speed: float, w: float, a_t: float,
               dt: float, steps: int = 4000) -> tuple[float, float, float, float]:  # fmt: skip
    """x, y, heading, speed after dt of constant yaw rate w and acceleration a_t along the
    heading, by RK4 on d(x, y, θ, s)/dt = (s cos θ, s sin θ, w, a_t)."""
    h = dt / steps

    def f(state: tuple[float, ...]) -> tuple[float, ...]:
        _, _, th, s = state
        return (s * math.cos(th), s * math.sin(th), w, a_t)

    state: tuple[float, ...] = (x, y, heading, speed)
    for _ in range(steps):
        k1 = f(state)
        k2 = f(tuple(v + h / 2 * k for v, k in zip(state, k1, strict=True)))
        k3 = f(tuple(v + h / 2 * k for v, k in zip(state, k2, strict=True)))
        k4 = f(tuple(v + h * k for v, k in zip(state, k3, strict=True)))
        state = tuple(v + h / 6 * (p + 2 * q + 2 * r + u)
                      for v, p, q, r, u in zip(state, k1, k2, k3, k4, strict=True))  # fmt: skip
    return state  # type: ignore[return-value]


CASES = [(0.6, 2.0, 0.5), (-1.2, -3.0, 0.4), (0.05, 1.0, 0.3), (2.5, 0.5, -0.2)]


@pytest.mark.parametrize(("w", "a_t", "dt"), CASES)
def test_turning_while_speeding_up_or_braking_follows_the_kinematics(
    w: float, a_t: float, dt: float
) -> None:
    """A car whose speed changes at a_t while it turns at w has, at the sample, the velocity
    s(cos θ, sin θ) and the acceleration a_t(cos θ, sin θ) + w·s(−sin θ, cos θ) (along the
    path, and the turn's centripetal part); the model follows it like the ODE does."""
    th, s = 0.9, 11.0
    c, sn = math.cos(th), math.sin(th)
    sample = Pose(0, 0.0, 1.0, 2.0, yaw=th, vx=s * c, vy=s * sn, wz=w,
                  ax=a_t * c - w * s * sn, ay=a_t * sn + w * s * c)  # fmt: skip
    x, y, heading, speed = integrated(1.0, 2.0, th, s, w, a_t, dt)
    for got in (project(sample, dt), project_many(columns([sample]), dt)):
        assert one(got.x) == pytest.approx(x, abs=1e-9)
        assert one(got.y) == pytest.approx(y, abs=1e-9)
        vx, vy = one(got.vx), one(got.vy)
        assert (vx, vy) == pytest.approx((speed * math.cos(heading), speed * math.sin(heading)),
                                         abs=1e-9)  # fmt: skip
        assert wrap_angle(one(got.yaw) - heading) == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------ scalar and array agree


def within(bound: float) -> st.SearchStrategy[float]:
    return st.floats(-bound, bound)


state = st.tuples(
    within(1e3), within(1e3), within(50.0), within(math.pi),  # x y z [m], yaw [rad]
    within(50.0), within(50.0), within(50.0),  # vx vy vz [m/s]
    st.one_of(st.just(0.0), within(1e-9), within(5.0)),  # wz [rad/s]: none, tiny, any
    within(20.0), within(20.0), within(20.0),  # ax ay az [m/s²]
    st.one_of(st.just(0.0), within(0.5)),  # dt [s]
)  # fmt: skip


@settings(max_examples=300, deadline=None)
@given(st.lists(state, min_size=1, max_size=12))
def test_scalar_and_array_forms_agree(states: list[tuple[float, ...]]) -> None:
    """Random states, several at once (so stopping and moving actors share one array)."""
    poses = [Pose(0, 0.0, x, y, z, 0.0, 0.0, yaw, vx, vy, vz, 0.0, 0.0, wz, ax, ay, az)
             for x, y, z, yaw, vx, vy, vz, wz, ax, ay, az, _ in states]  # fmt: skip
    dt = np.array([s[-1] for s in states])
    many = project_many(columns(poses), dt)
    for i, (pose, step) in enumerate(zip(poses, dt.tolist(), strict=True)):
        one = project(pose, step)
        for f in FIELDS:
            assert float(np.asarray(getattr(many, f))[i]) == pytest.approx(
                getattr(one, f), rel=1e-12, abs=1e-9), f  # fmt: skip
        assert wrap_angle(float(many.yaw[i]) - one.yaw) == pytest.approx(0.0, abs=1e-9)


def test_no_actors_project_to_no_actors() -> None:
    for npc in (False, True):
        empty = columns([])._replace(ax=None) if npc else columns([])
        assert all(np.size(v) == 0 for v in project_many(empty, np.zeros(0)))


# ------------------------------------------------------------------ the authority and a view


def ego(pose_bytes: bytes) -> dict[str, EgoTrack]:
    info = m.EgoInfo("bike-1", "bike", "bicycle", m.Extent(1.8, 0.6, 1.7), 90.0)
    track = EgoTrack(info, "test", 0.0)
    track.last_pose = m.decode_pose(pose_bytes)  # as the authority's pose intake decodes it
    return {"bike-1": track}


@pytest.mark.parametrize("mode", ["present", "past"])
def test_the_collision_check_and_a_remote_view_put_an_ego_at_one_place(mode: str) -> None:
    """One sample of a rider on a 15 m circle at 6 m/s, sent as wire bytes to both; each
    projects it to the time it works at. Both land at the same place, on the circle."""
    circle = Circle(r=15.0, v=6.0, left=True)
    wire = m.encode_pose(circle.pose(10.0, 1.0))
    view = WorldView("me", InterpolationSettings(render_mode=mode))  # type: ignore[arg-type]
    view.intake.present("bike-1")
    view.intake.pose("bike-1", wire, 10.01)
    view.update(10.2)
    (drawn,) = view.ego_views(10.2)
    assert drawn.render_t > 10.1  # projected beyond the sample in either mode
    (checked,) = egos_at(drawn.render_t, ego(wire), 0.5)
    for name in ("x", "y", "vx", "vy"):
        assert getattr(checked, name) == pytest.approx(getattr(drawn, name), abs=1e-9), name
    assert wrap_angle(checked.yaw - drawn.yaw) == pytest.approx(0.0, abs=1e-9)
    truth = circle.pose(drawn.render_t, 1.0)  # the wire carries f32 positions, f16 rates
    assert (drawn.x, drawn.y) == pytest.approx((truth.x, truth.y), abs=1e-3)
    assert wrap_angle(drawn.yaw - truth.yaw) == pytest.approx(0.0, abs=1e-3)
