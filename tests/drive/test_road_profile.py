"""The road's vertical profile through the drive loop: heave, pitch and wheel shake.

Every cue is read as the motion server reads it: the loop's cue packed into the 21-byte
FRAME_UPDATE and decoded with the server's limits (hal.motion_packet). Signs are the packet's:
heave up positive, pitch nose up positive.
"""

from __future__ import annotations

import math

import msgspec
import pytest
from carlaverse_nodes.drive.vehicle_loop import DriveLoop, LoopOutput

from carlaverse.hal import motion_packet
from carlaverse.hal.motion_packet import MotionFrame
from carlaverse.physics.road_surface import Kerb, RoadSurface, SpeedBump
from carlaverse.physics.roughness import RoughnessClass
from tests.drive.support import DT, desktop_loop, keys


def loop_on(
    surface: RoadSurface, roughness: RoughnessClass | None = None, **cueing: float
) -> DriveLoop:
    """The desktop car on `surface`, with the node's own road `roughness` where it names none
    and motion-cueing gains changed by `cueing`."""
    base = desktop_loop()
    road = msgspec.structs.replace(base.config.road, roughness_class=roughness)
    mca = msgspec.structs.replace(base.config.motion_cueing, **cueing)
    config = msgspec.structs.replace(base.config, road=road, motion_cueing=mca)
    loop = DriveLoop(config, base.vehicle)
    loop.set_surface(surface)
    return loop


def drive_east(
    loop: DriveLoop, speed_mps: float, seconds: float, steer: float = 0.0
) -> list[LoopOutput]:
    """From the origin heading east at `speed_mps`, a driver holding that speed (throttle by
    a proportional foot) and the wheel at `steer`."""
    loop.place(0.0, 0.0, 0.0, speed_mps)
    loop.engage_drive()
    outs: list[LoopOutput] = []
    speed = speed_mps
    for _ in range(round(seconds / DT)):
        throttle = min(1.0, max(0.0, 0.15 + 2.0 * (speed_mps - speed)))
        out = loop.step(DT, keys(steer, throttle, 0.0))
        speed = out.speed_mps
        outs.append(out)
    return outs


def as_decoded(out: LoopOutput) -> MotionFrame:
    """The loop's cue as the motion server sees it: encoded, sent, decoded (float32)."""
    m = out.motion
    frame = MotionFrame(m.roll, m.pitch, m.heave, m.rpm, m.torque)
    return motion_packet.decode(motion_packet.encode(frame))


def first_excursion(values: list[float], threshold: float) -> float:
    """The first value beyond ±threshold (its sign says which way the cue went first)."""
    return next(v for v in values if abs(v) > threshold)


# A speed hump across the road at x = 20 m: a raised cosine of height h over L of travel.
BUMP_X, H, L = 20.0, 0.08, 3.0  # [m]
V = 6.0  # [m/s] ~22 km/h, a plausible speed over a hump
BUMP = RoadSurface(bumps=[SpeedBump(line=[(BUMP_X, -4.0), (BUMP_X, 4.0)], height_m=H, length_m=L)])


def test_a_speed_bump_accelerates_the_wheel_as_its_shape_says_and_heaves_the_rig_up_first() -> None:
    outs = drive_east(loop_on(BUMP), V, 5.0)
    # The wheel, before any suspension, follows z(d) = h/2·(1 + cos(2π·d/L)) for |d| ≤ L/2,
    # d = v·t past the crest line. z̈ = −h/2·(2π/L)²·v²·cos(2π·d/L): at the foot (d = −L/2,
    # cos = −1) it pushes up with a_peak = h/2·(2πv/L)² = 2h·(πv/L)² — 6.3 m/s² here — and at
    # the crest it pulls down as hard. Measured: the second difference of the road height
    # under the front axle, tick by tick.
    z = [o.vertical.road_front_m for o in outs]
    accel = [0.0, *((z[i + 1] - 2 * z[i] + z[i - 1]) / DT**2 for i in range(1, len(z) - 1))]
    foot = next(i for i, zi in enumerate(z) if zi > 0.0)  # the front wheels reach the hump
    i_up = max(range(foot, foot + 20), key=accel.__getitem__)
    v = outs[i_up].speed_mps
    expected = 2 * H * (math.pi * v / L) ** 2
    # 2 %: the held speed wanders by < 0.5 % (1 % in v²); the second difference's own error at
    # v/L = 2 Hz and 1 kHz is (ω·dt)²/12 ≈ 1e−5.
    assert accel[i_up] == pytest.approx(expected, rel=0.02)
    crest = foot + round(L / 2 / v / DT)
    assert min(accel[crest - 20 : crest + 20]) == pytest.approx(-expected, rel=0.02)
    assert v == pytest.approx(V, rel=0.03)

    # The body goes up first, so the rig's heave (the paper's vertical-jerk term) does too,
    # and clearly: more than a fifth of the ±25 mm platform.
    frames = [as_decoded(o) for o in outs]
    heave = [f.heave for f in frames]
    assert first_excursion(heave, 0.001) > 0.0
    assert max(heave) > 0.005
    # The front wheels climb first: the nose goes up first (packet: nose up positive).
    before = frames[foot - 1].pitch  # [rad] the held-speed cue just before the hump
    assert first_excursion([f.pitch - before for f in frames[foot:]], 0.003) > 0.0


def test_climbing_a_kerb_pitches_the_nose_up_while_only_the_front_is_on_it() -> None:
    # A 10 cm kerb, its edge across the road at x = 10 m, the raised area beyond to x = 40 m.
    kerb = Kerb(polygon=[(10.0, -5.0), (40.0, -5.0), (40.0, 5.0), (10.0, 5.0)], height_m=0.1,
                edge_m=0.1)  # fmt: skip
    outs = drive_east(loop_on(RoadSurface(kerbs=[kerb])), 2.0, 6.0)
    # The edge is half a cosine: z(e) = h/2·(1 − cos(π·e/w)) over the edge width w, e = v·t
    # into it. z̈ = h/2·(π·v/w)²·cos(π·e/w): the wheel is pushed up hardest at the foot,
    # a = h·(π·v/w)²/2 ≈ 197 m/s² here (a kerb is sharp), and pulled down as hard at the top.
    z = [o.vertical.road_front_m for o in outs]
    accel = [(z[i + 1] - 2 * z[i] + z[i - 1]) / DT**2 for i in range(1, len(z) - 1)]
    foot = next(i for i, zi in enumerate(z) if zi > 0.0)
    v = outs[foot].speed_mps
    expected = 0.1 * (math.pi * v / 0.1) ** 2 / 2
    # 3 %: the held speed (< 1 % in v²) and the edge's 50 ticks, whose second difference is
    # (ω·dt)²/12 ≈ 0.03 % low; the foot falls between two ticks, ±1 tick of 50 in the peak.
    assert max(accel[foot - 5 : foot + 5]) == pytest.approx(expected, rel=0.03)
    straddling = [o for o in outs if o.vertical.road_front_m > 0.099 > o.vertical.road_rear_m]
    assert len(straddling) > 0.9 * 2.64 / 2.0 / DT  # ~1.3 s at 2 m/s over the wheelbase
    # With the front axle up 10 cm and the rear not, the body settles nose up by
    # atan(0.1/2.64) = 38 mrad: springs have no static offset. By the last tick before the
    # rear climbs, 1.3 s on, the body's bounce (ζ = c/(2√k) = 0.38, ω = √63.3 = 8 rad/s: the
    # Golden Car) has decayed to e^(−ζω·1.3 s) = 2 %: 5 % covers it.
    last = straddling[-1]
    assert last.vertical.pitch_rad == pytest.approx(math.atan(0.1 / 2.64), rel=0.05)
    cues = [as_decoded(o).pitch for o in straddling]
    assert max(cues) > 0.02 and min(cues) > 0.0  # the rig noses up, never down, on the climb


def test_on_a_smooth_flat_road_nothing_heaves_or_shakes() -> None:
    # Only the vertical-jerk term drives the heave here (k_jx = 0: the longitudinal jerk of
    # the driver's foot heaves the rig too, by design), so any heave would be the road's.
    loop = loop_on(RoadSurface(), roughness=None, k_jx_m_per_mps3=0.0)
    outs = drive_east(loop, 10.0, 4.0, steer=0.2)  # a steady curve at 36 km/h
    assert outs[-1].speed_mps == pytest.approx(10.0, rel=0.03) and abs(outs[-1].yaw) > 0.3
    # The road gives nothing: no vertical acceleration, no road pitch, no wheel shake ...
    assert all(o.vertical == outs[0].vertical for o in outs)
    assert outs[0].vertical.heave_accel_mps2 == 0.0 and outs[0].vertical.pitch_rad == 0.0
    assert outs[0].vertical.wheel_accel_mps2 == 0.0
    # ... so the rig does not heave at all, and the wheel's vibration is the engine's alone:
    # its firing frequency.
    assert all(as_decoded(o).heave == 0.0 for o in outs)
    last = outs[-1]
    firing_hz = last.rpm / 60.0 * 3 / 2  # three cylinders, four-stroke
    assert last.ffb.vibration_frequency_hz == round(firing_hz)


def shake(roughness: RoughnessClass) -> float:
    """Mean FFB vibration magnitude at 50 km/h on a road of that class, once settled."""
    outs = drive_east(loop_on(RoadSurface(), roughness), 13.9, 3.0)[1000:]
    return sum(o.ffb.vibration_magnitude for o in outs) / len(outs)


def test_wheel_shake_grows_with_the_roughness_class() -> None:
    # ISO 8608: each class has four times the displacement PSD of the one before, so twice
    # the amplitude; the suspension and tyre are linear and the shake is the wheel's RMS
    # acceleration, so two classes up is four times the shake (same seed: the same road,
    # scaled). 10 %: the engine's share of the frequency choice and the rounding to units.
    a, c, e = shake("A"), shake("C"), shake("E")
    assert 0.0 < a < c < e
    assert c / a == pytest.approx(4.0, rel=0.1)
    assert e / c == pytest.approx(4.0, rel=0.1)
