"""DriveLoop end to end, without network or devices: standstill, impulses, logic, telemetry."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.drive.vehicle_loop import DriveLoop

from carlaverse.messages import (
    LIGHT_BRAKE,
    LIGHT_LEFT_BLINKER,
    LIGHT_PARKING,
    LIGHT_REVERSE,
    LIGHT_RIGHT_BLINKER,
    Impulse,
)
from tests.drive.support import DT, IDLE, desktop_loop, keys, run, tap


def impulse(seq: int, j: tuple[float, float, float], point: tuple[float, float, float],
            t: float = 0.0) -> Impulse:  # fmt: skip
    return Impulse(seq, t, 1, j, point, (0.0, 1.0, 0.0), "npc-1", "car", 5.0)


def test_stands_still_without_drift_for_60_s_in_the_loop() -> None:
    loop = desktop_loop()
    loop.place(3.0, 4.0, 1.0)
    loop.engage_drive()
    out = run(loop, 60.0)  # 60 000 ticks at 1 kHz, engine idling in D, hands and feet off
    # Exactly still: see test_scenarios.py — Coulomb resistances and regularised slip.
    assert (out.x, out.y, out.yaw) == pytest.approx((3.0, 4.0, 1.0), abs=1e-9)
    assert out.speed_mps == 0.0 and out.gear == 1
    # And no phantom cue at rest: the rig and the wheel are quiet.
    assert (out.motion.roll, out.motion.pitch, out.motion.heave) == (0.0, 0.0, 0.0)
    assert out.ffb.constant_force == 0


def twin_loops(speed: float = 10.0) -> tuple[DriveLoop, DriveLoop]:
    loops = (desktop_loop(), desktop_loop())
    for loop in loops:
        loop.place(0.0, 0.0, 0.3, speed)
        loop.engage_drive()
        run(loop, 0.5, keys(0.0, 0.2))
    return loops


def test_impulse_changes_velocity_by_j_over_m_and_jolts_wheel_and_rig() -> None:
    hit, calm = twin_loops()
    mass = hit.vehicle.body.mass_kg
    j = (-1200.0, 2600.0, 300.0)  # [N·s] an oblique side hit, slightly upward
    ahead = (math.cos(0.3) * 1.2, math.sin(0.3) * 1.2, 0.5)  # contact ahead of the CG
    sample = keys(0.0, 0.2)
    out_hit = hit.step(DT, sample, [impulse(1, j, ahead)])
    out_calm = calm.step(DT, sample)
    assert out_hit.impulses_applied == 1
    dv = (out_hit.vx - out_calm.vx, out_hit.vy - out_calm.vy)
    expected = (j[0] / mass, j[1] / mass)
    # 1 %: the acceptance bound. The twin isolates the impulse from everything else; what
    # remains is one tick of the hit car's extra tyre force, ≤ μ·g·dt ≈ 0.01 m/s against
    # |J/m| ≈ 2.1 m/s, i.e. ≤ 0.5 %.
    assert math.dist(dv, expected) <= 0.01 * math.hypot(*expected)
    assert out_hit.yaw_rate != pytest.approx(out_calm.yaw_rate)  # off-centre: it spins
    # The wheel kicks and buzzes ...
    assert abs(out_hit.ffb.constant_force - out_calm.ffb.constant_force) > 1000
    assert out_hit.ffb.vibration_magnitude > out_calm.ffb.vibration_magnitude + 1000
    # ... and the rig heaves: compare the peak over the next 0.2 s.
    hit_heave = max(abs(hit.step(DT, sample).motion.heave) for _ in range(200))
    calm_heave = max(abs(calm.step(DT, sample).motion.heave) for _ in range(200))
    assert hit_heave > calm_heave + 0.005  # [m] a clearly felt jolt (limit 0.025 m)


def test_impulses_are_applied_once_when_due_and_bad_ones_dropped() -> None:
    t = [0.0]
    loop = desktop_loop(clock=lambda: t[0])
    loop.engage_drive()
    early = impulse(7, (1350.0, 0.0, 0.0), (0.0, 0.0, 0.0), t=0.5)
    assert loop.step(DT, IDLE, [early]).impulses_applied == 0  # not due yet
    t[0] = 0.5
    out = loop.step(DT, IDLE, [early])  # re-delivered copy: ignored, the first one applies
    assert out.impulses_applied == 1
    assert out.speed_mps == pytest.approx(1.0, abs=0.01)  # 1350 N·s / 1350 kg
    assert loop.step(DT, IDLE, [early]).impulses_applied == 0
    nan = impulse(8, (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0))
    huge = impulse(9, (1e9, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert loop.step(DT, IDLE, [nan, huge]).impulses_applied == 0
    assert loop.impulses_dropped == 2


def test_indicator_lights_and_published_state_changes() -> None:
    loop = desktop_loop()
    assert loop.step(DT, IDLE).state_changed  # the first tick always publishes
    assert not loop.step(DT, IDLE).state_changed
    out = tap(loop, "indicator_left")
    assert out.indicator == "left" and out.lights & LIGHT_LEFT_BLINKER and out.state_changed
    out = tap(loop, "hazard")
    assert out.indicator == "hazard"
    assert out.lights & (LIGHT_LEFT_BLINKER | LIGHT_RIGHT_BLINKER) == (
        LIGHT_LEFT_BLINKER | LIGHT_RIGHT_BLINKER
    )
    assert tap(loop, "indicator_right").indicator_state == "hazard_right"
    assert tap(loop, "indicator_reset").indicator_state == "hazard_right"  # LCA off
    tap(loop, "lane_change_assist")
    out = tap(loop, "indicator_reset")
    assert out.lca_active and out.indicator_state == "hazard"
    out = tap(loop, "lights_cycle")
    assert out.lights & LIGHT_PARKING
    blinks = {loop.step(DT, IDLE).blink_on for _ in range(700)}
    assert blinks == {True, False}  # the dashboard sees the flasher


def test_gears_and_state_driven_lamps() -> None:
    loop = desktop_loop()
    assert loop.step(DT, IDLE).gear == 0  # N at start
    assert tap(loop, "gear_down").gear == -1  # N → R at standstill
    out = loop.step(DT, keys(0.0, 0.0, 0.5))
    assert out.lights & LIGHT_REVERSE and out.lights & LIGHT_BRAKE
    tap(loop, "gear_up")
    assert tap(loop, "gear_up").gear == 1  # R → N → D
    out = run(loop, 3.0, keys(0.0, 1.0))
    assert out.speed_kmh > 20.0 and out.rpm > 1000.0 and not out.lights & LIGHT_REVERSE
    assert out.motion.pitch > 0.0  # accelerating: nose up


def test_telemetry_converts_to_wire_messages() -> None:
    loop = desktop_loop()
    loop.place(1.0, 2.0, 0.5, 10.0)
    loop.engage_drive()
    out = loop.step(DT, keys(0.3, 0.5))
    pose = out.pose(seq=4, t=12.5)
    assert (pose.seq, pose.t, pose.x, pose.y, pose.yaw) == (4, 12.5, out.x, out.y, out.yaw)
    assert math.hypot(pose.vx, pose.vy) == pytest.approx(10.0, rel=0.01)
    state = out.ego_state(seq=1, t=12.5)
    assert (state.gear, state.lights, state.indicator, state.adas) == (
        out.gear,
        out.lights,
        "off",
        "",
    )
    assert state.speed_mps == out.speed_mps
