"""Desktop mode without VR: the shipped `walk-desktop` config, keys and mouse on SDL's dummy
video driver with posted events (as a focused window would get them), through the walk
control loop on a manual clock."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.walk.config import WalkNodeConfig
from carlaverse_nodes.walk.walk_control import WalkControl

from carlaverse.config import load_config
from carlaverse.hal import open_input, open_xr
from tests.hal.helpers import ManualClock
from tests.hal.test_input import pygame_dummy  # noqa: F401  (the SDL dummy-video fixture)

DT = 1.0 / 90.0  # [s] the loop's period


def run(control: WalkControl, clock: ManualClock, seconds: float):
    out = None
    for _ in range(round(seconds / DT)):
        clock.advance(DT)
        out = control.tick(DT)
    return out


def test_wasd_and_mouse_look_walk_where_the_head_looks(pygame_dummy) -> None:  # noqa: F811
    pg = pygame_dummy
    config = load_config("walk-desktop", WalkNodeConfig)
    clock = ManualClock()
    headset = open_xr(config.xr, clock=clock)
    keys = open_input(config.input, clock=clock)
    control = WalkControl(config, headset, keys)
    control.place(100.0, 50.0, 0.0)  # the stage faces east
    mouse = lambda dx, dy: pg.event.post(  # noqa: E731
        pg.event.Event(pg.MOUSEMOTION, rel=(dx, dy), pos=(0, 0), buttons=(0, 0, 0)))  # fmt: skip
    key = lambda kind, name: pg.event.post(pg.event.Event(kind, key=pg.key.key_code(name)))  # noqa: E731

    mouse(-200, 0)  # 200 px left at 0.15°/px: the head turns 30° left
    key(pg.KEYDOWN, "w")
    out = run(control, clock, 2.0)
    assert out.head.yaw == pytest.approx(math.radians(30.0))
    assert out.head.z == pytest.approx(1.65)
    assert out.speed_mps == pytest.approx(1.4)  # the walk limit
    assert math.atan2(out.vy, out.vx) == pytest.approx(math.radians(30.0))
    # w ramps to full in 1/6 s, speed to 1.4 m/s at 1.5 m/s² in 0.93 s: ~2 s of walking
    # cover between 1.4·(2 − 0.17 − 0.93) + 0.65 = 1.9 m and 2.8 m
    walked = math.hypot(out.head.x - 100.0, out.head.y - 50.0)
    assert 1.9 < walked < 2.8

    mouse(0, -100)  # mouse up: look 15° up; walking stays level and on course
    key(pg.KEYDOWN, "left shift")
    out = run(control, clock, 2.0)
    assert out.head.pitch == pytest.approx(math.radians(-15.0))  # ISO: nose up is negative
    assert out.speed_mps == pytest.approx(3.0)  # running
    assert math.atan2(out.vy, out.vx) == pytest.approx(math.radians(30.0))

    key(pg.KEYUP, "w")
    key(pg.KEYUP, "left shift")
    out = run(control, clock, 1.5)  # 3 m/s² stops a 3 m/s run within 1 s
    assert out.speed_mps == 0.0
    keys.close()
    headset.close()


def test_mouse_look_stops_at_the_pitch_limit(pygame_dummy) -> None:  # noqa: F811
    pg = pygame_dummy
    clock = ManualClock()
    headset = open_xr({"backend": "mouse", "options": {"max_pitch_deg": 60}}, clock=clock)
    pg.event.post(pg.event.Event(pg.MOUSEMOTION, rel=(0, -2000), pos=(0, 0), buttons=(0, 0, 0)))
    w, x, _, _ = headset.pose().orientation
    assert 2 * math.atan2(x, w) == pytest.approx(math.radians(60.0))  # about +x: looking up


def test_a_gamepad_stick_walks_and_its_button_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """A real SDL virtual gamepad through the pygame backend: left stick and a run button."""
    from carlaverse_nodes.walk.config import WalkNodeConfig

    from carlaverse.hal import InputConfig, XrConfig
    from tests.hal.sdl import VirtualJoystick

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pytest.importorskip("pygame")
    pad = VirtualJoystick(axes=2, buttons=2, hats=0)
    try:
        mapping = {"axes": {"move_x": {"index": 0}, "move_y": {"index": 1, "invert": True}},
                   "buttons": {"run": 0}}  # SDL's stick y grows backwards  # fmt: skip
        config = WalkNodeConfig(xr=XrConfig(backend="mouse"),
                                input=InputConfig(backend="pygame", options=mapping))  # fmt: skip
        clock = ManualClock()
        pad_input = open_input(config.input, clock=clock)
        control = WalkControl(config, open_xr(config.xr, clock=clock), pad_input)
        control.place(0.0, 0.0, math.pi / 2)  # the stage faces north
        pad.axis(1, -1.0)  # stick fully forward
        out = run(control, clock, 1.5)
        assert out.speed_mps == pytest.approx(1.4, abs=1e-3)  # SDL axes are 16-bit
        assert math.atan2(out.vy, out.vx) == pytest.approx(math.pi / 2)
        pad.axis(0, 1.0)  # and fully right: north-east, still at most the walk speed
        pad.button(0, True)  # run
        out = run(control, clock, 2.5)
        assert out.speed_mps == pytest.approx(3.0, abs=1e-3)
        assert math.atan2(out.vy, out.vx) == pytest.approx(math.pi / 4, abs=1e-3)
        pad_input.close()
    finally:
        pad.detach()
