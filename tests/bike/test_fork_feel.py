"""Fork force feedback against physical statements, end to end through the real ffb-server.

Conventions, each taken from where it is defined, not from the fork's code:

- Steer δ > 0 turns the fork LEFT: the bicycle's yaw is counter-clockwise from +x and
  ψ̇ = v·cos β·tan δ / w (`carlaverse.physics.bicycle`), so δ > 0 turns the bike left.
- On the wire, `constant_force` > 0 pushes the bar toward the RIGHT (`carlaverse.hal.ffb_packet`:
  "sign as spring_offset", full left .. full right; `doctor --ffb` sends "constant force right"
  as +). So the torque the rider feels toward the right is constant_force / 10000 · full scale.

Each command below is sent by the real `udp` FFB client over a UDP socket on 127.0.0.1 to a
real `FfbServer`, and judged as the server decoded and applied it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, RoadSettings, resolve_table
from carlaverse_nodes.bike.fork_feel import ForkFeel, ForkFeelParams, steer_torque

from carlaverse.hal import open_ffb
from carlaverse.hal.ffb_packet import FULL_SCALE, FfbCommand
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from carlaverse.messages import Impulse
from carlaverse.physics.bicycle import BicycleParams
from tests.support import wait_until

G = 9.81  # [m/s²]
DT = 0.005  # [s] the bike loop's 200 Hz tick
CONFIG = BikeNodeConfig(road=RoadSettings(roughness=0.0))  # no texture: the force alone
BIKE, FORK = CONFIG.bicycle, CONFIG.fork

Applied = Callable[[FfbCommand], FfbCommand]


@pytest.fixture
def fork_motor() -> Iterator[Applied]:
    """Send a command as the bike node does (`ffb: {backend: udp}`); what the server applied."""
    actuator = LogActuator(LogActuatorOptions())
    with FfbServer(actuator, "127.0.0.1", 0) as server:
        device = open_ffb({"backend": "udp", "options": {"port": server.address[1]}})

        def applied(command: FfbCommand) -> FfbCommand:
            before = server.stats.applied
            device.send(command)
            wait_until(lambda: server.stats.applied > before, 5, "the command applied", 0.001)
            return actuator.current

        yield applied
        device.close()


def felt_toward_right_nm(command: FfbCommand, full_scale_nm: float) -> float:
    """The bar torque [N·m] the rider feels toward the right, from the wire's scale."""
    return command.constant_force / FULL_SCALE * full_scale_nm


def ride(speed_mps: float, steer_rad: float, seconds: float = 0.5) -> FfbCommand:
    """The fork command after riding `seconds` at a fixed wheel speed and fork angle."""
    loop = BikeLoop(CONFIG, resolve_table(CONFIG))
    axis = steer_rad / BIKE.max_steer_rad
    for _ in range(round(seconds / DT)):
        out = loop.step(DT, speed_mps, axis, 0.0)
    return out.ffb


# Published measured steer torques: riders on instrumented bicycles apply a few N·m in normal
# riding (Moore, "Steer torque accuracy", UC Davis Sports Biomechanics Lab: the Davis
# instrumented bicycle's steer-column sensor was checked for the 1–3 N·m range riding needs;
# Cain, Ashton-Miller & Perkins 2016, "On the skill of balancing while riding a bicycle",
# PLoS ONE 11(2) e0149340, at 1–7 m/s). A 5 m/s ride with the fork at 0.05 rad is ordinary
# riding: a turn of radius w/(δ·cos λ) ≈ 23 m, 1.1 m/s² lateral.
RIDING_BAND_NM = (1.0, 3.0)


@pytest.mark.parametrize("steer_rad", [0.05, -0.05])
def test_a_turned_fork_is_pushed_back_toward_centre(fork_motor: Applied, steer_rad: float) -> None:
    """At 5 m/s the trail pulls the fork back: turned left → pushed right, and vice versa."""
    applied = fork_motor(ride(5.0, steer_rad))
    toward_right = felt_toward_right_nm(applied, FORK.full_scale_nm)
    assert math.copysign(1.0, toward_right) == math.copysign(1.0, steer_rad)  # against δ
    assert RIDING_BAND_NM[0] <= abs(toward_right) <= RIDING_BAND_NM[1]


def wheel_flop_nm(bike: BicycleParams, fork: ForkFeelParams, steer_rad: float) -> float:
    """Wheel flop (Wilson & Papadopoulos, Bicycling Science; Cossalter, Motorcycle Dynamics):
    turning the fork drops the head of the frame by the flop distance f·sin δ, with
    f = c·sin ε·cos ε for trail c and head angle ε = 90° − λ; the front wheel's load W_f pushes
    it down, so gravity turns the fork further in with W_f·f·sin δ. W_f is the share of the
    weight on the front wheel, m·g·l_r/w, for a centre of gravity l_r ahead of the rear wheel."""
    head_angle = math.pi / 2 - fork.steer_axis_tilt_rad
    flop_m = fork.trail_m * math.sin(head_angle) * math.cos(head_angle)
    front_weight_n = bike.mass_kg * G * bike.cg_to_rear_m / bike.wheelbase_m
    return front_weight_n * flop_m * math.sin(steer_rad)


@pytest.mark.parametrize("steer_rad", [0.1, -0.3])
def test_standing_still_gravity_turns_the_fork_further_in(
    fork_motor: Applied, steer_rad: float
) -> None:
    """Wheel flop: a parked bike's bar falls to the side it is turned to."""
    applied = fork_motor(ride(0.0, steer_rad))
    toward_left = -felt_toward_right_nm(applied, FORK.full_scale_nm)
    expected = wheel_flop_nm(BIKE, FORK, steer_rad)  # same sign as δ: further in
    assert math.copysign(1.0, toward_left) == math.copysign(1.0, steer_rad)
    # the wire carries whole units of full_scale/10000 N·m
    assert toward_left == pytest.approx(expected, abs=FORK.full_scale_nm / FULL_SCALE)


def test_a_shove_to_the_right_kicks_the_fork_right(fork_motor: Applied) -> None:
    """A caster turns toward where it is pushed: the ground holds the contact patch, which
    trails behind the steer axis, so a bike shoved right swings its front wheel to the right."""
    loop = BikeLoop(CONFIG, resolve_table(CONFIG))
    loop.place(0.0, 0.0, 0.0)  # heading +x: its right is −y
    loop.step(DT, 3.0, 0.0, 0.0)
    shove = Impulse(1, 0.0, 1, (0.0, -180.0, 0.0), (0.0, 0.0, 0.5), (0.0, 1.0, 0.0), "car-1",
                    "car", 2.0)  # 2 m/s to the right  # fmt: skip
    out = loop.step(DT, 3.0, 0.0, 0.0, [shove], now=1.0)
    assert out.impulses_applied == 1
    applied = fork_motor(out.ffb)
    assert felt_toward_right_nm(applied, FORK.full_scale_nm) > 0
    assert applied.vibration_magnitude > 1000  # and it shakes


# --- the model itself, against the published benchmark bicycle ------------------------------

# Meijaard, Papadopoulos, Ruina & Schwab 2007, "Linearized dynamics equations for the balance
# and steer of a bicycle: a benchmark and review", Proc. R. Soc. A 463, table 1 (parameters)
# and the published coefficients of M q̈ + v C1 q̇ + (g K0 + v² K2) q = f, steer row:
BENCH_K0_DD = -0.80329488458618  # [kg·m] K0δδ
BENCH_K2_DD = 2.65431523794604  # [kg·m] K2δδ
W, C, LAM = 1.02, 0.08, math.pi / 10  # wheelbase, trail [m]; steer axis tilt [rad]
M_R, M_B, M_H, M_F = 2.0, 85.0, 4.0, 3.0  # rear wheel, body, handlebar, front wheel [kg]
X_B, X_H, Z_H = 0.3, 0.9, -0.7  # body and handlebar centres of mass [m] (z down)
R_F, I_FYY = 0.35, 0.28  # front wheel radius [m] and spin inertia [kg·m²]


def benchmark_bicycle() -> tuple[BicycleParams, ForkFeelParams]:
    """The benchmark in our parameters: the total mass with its centre of mass x_T ahead of the
    rear contact; the front assembly's mass offset m_A·u_A from the steer axis (benchmark
    appendix: u_A = (x_A − w − c)·cos λ − z_A·sin λ)."""
    m_t = M_R + M_B + M_H + M_F
    x_t = (M_B * X_B + M_H * X_H + M_F * W) / m_t
    m_a = M_H + M_F
    x_a = (M_H * X_H + M_F * W) / m_a
    z_a = (M_H * Z_H - M_F * R_F) / m_a
    u_a = (x_a - W - C) * math.cos(LAM) - z_a * math.sin(LAM)
    bike = BicycleParams(mass_kg=m_t, wheelbase_m=W, cg_to_rear_m=x_t)
    fork = ForkFeelParams(
        trail_m=C, steer_axis_tilt_rad=LAM, front_assembly_offset_kgm=m_a * u_a,
        front_wheel_spin_inertia_kgm2=I_FYY, front_wheel_radius_m=R_F,
    )  # fmt: skip
    return bike, fork


@pytest.mark.parametrize("speed_mps", [0.0, 2.0, 5.0, 8.0])
def test_the_model_is_the_upright_benchmark_steer_stiffness(speed_mps: float) -> None:
    """Upright (φ = 0) and held at δ, the benchmark's rider holds T = (g·K0δδ + v²·K2δδ)·δ; the
    fork pushes back with −T. δ = 1 mrad keeps sin δ = tan δ = δ within 1e-6."""
    bike, fork = benchmark_bicycle()
    delta = 1e-3
    expected = -(G * BENCH_K0_DD + speed_mps**2 * BENCH_K2_DD) * delta
    assert steer_torque(fork, bike, speed_mps, delta) == pytest.approx(expected, rel=1e-5)


def test_surface_vibration_grows_with_speed_and_roughness() -> None:
    fork = ForkFeel(FORK, BIKE)
    smooth = fork.update(0.005, 5.0, 0.0, 0.1)
    rough = fork.update(0.005, 5.0, 0.0, 0.5)
    fast = fork.update(0.005, 8.0, 0.0, 0.5)
    assert smooth.vibration_magnitude == 300  # 600 · 5 m/s · 0.1
    assert rough.vibration_magnitude == 1500 < fast.vibration_magnitude == 2400
    assert rough.vibration_frequency_hz == FORK.texture_hz
    assert fork.update(0.005, 0.0, 0.0, 1.0).vibration_magnitude == 0  # standing: no texture


def test_a_jolt_fades_with_its_time_constant() -> None:
    fork = ForkFeel(FORK, BIKE)
    fork.add_jolt(2.0, -1.0)  # 2 m/s knock, pushed to the right
    first = fork.update(0.005, 3.0, 0.0, 0.1)
    assert first.vibration_magnitude == 6000 and first.vibration_frequency_hz == FORK.jolt_hz
    steps = round(0.6 / 0.005)  # 4 time constants of 0.15 s: e^−4 of the kick is left
    for _ in range(steps):
        last = fork.update(0.005, 3.0, 0.0, 0.1)
    assert last.vibration_magnitude == 180 and last.vibration_frequency_hz == FORK.texture_hz
    assert abs(last.constant_force) <= round(6000 * math.exp(-4)) + 1
