"""Input devices: the scripted `sim` driver (profile, random walk, path following), the
pygame backend on a real SDL virtual wheel, and the keyboard on SDL's dummy video driver."""

from __future__ import annotations

import math

import pytest

from carlaverse import hal
from carlaverse.config import ConfigError, convert
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.input import InputDevice
from carlaverse.hal.input.sim import SimInput, SimInputOptions
from tests.hal.helpers import ManualClock

PROFILE = {
    "axes": ["steer", "throttle", "brake"],
    "buttons": ["horn"],
    "profile": [
        {"t": 0, "axes": {"throttle": 0.0, "steer": 0.0}},
        {"t": 2, "axes": {"throttle": 0.8, "steer": -0.5}, "buttons": {"horn": True}},
        {"t": 4, "axes": {"throttle": 0.0, "brake": 1.0}, "buttons": {"horn": False}},
    ],
}


def sim(options: dict, clock: ManualClock) -> SimInput:
    return hal.open_input({"backend": "sim", "options": options}, clock=clock)


def test_profile_interpolates_axes_and_holds_buttons() -> None:
    clock = ManualClock()
    device = sim(PROFILE, clock)
    samples = {}
    for t in (0.0, 1.0, 2.0, 3.0, 5.0):
        clock.t = 1000.0 + t
        samples[t] = device.poll()
    assert samples[1.0].axes == pytest.approx({"steer": -0.25, "throttle": 0.4, "brake": 1.0})
    assert samples[1.0].buttons == {"horn": False} and samples[2.0].buttons == {"horn": True}
    assert samples[3.0].axes["throttle"] == pytest.approx(0.4)
    assert samples[5.0].axes == {"steer": -0.5, "throttle": 0.0, "brake": 1.0}
    assert samples[5.0].buttons == {"horn": False} and samples[5.0].t == 1005.0


def test_profile_loops() -> None:
    clock = ManualClock()
    device = sim({**PROFILE, "loop": True}, clock)
    clock.advance(5.0)  # 5 s into a 4 s loop = 1 s
    assert device.poll().axes["throttle"] == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"mode": "path"}, "needs a `path:` block"),
        ({"profile": [{"t": 0, "axes": {"stear": 1}}]}, "['stear'] not in axes"),
        ({"profile": [{"t": 2}, {"t": 1}]}, "increasing t"),
        ({"profile": [{"t": -1}]}, ">= 0"),
    ],
)
def test_bad_sim_options_are_config_errors(options: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        sim(options, ManualClock())


def test_random_walk_is_deterministic_whatever_the_polling() -> None:
    options = {"mode": "random_walk", "random_walk": {"seed": 7, "sigma": 0.5}}
    often, once, other = ManualClock(), ManualClock(), ManualClock()
    a, b = sim(options, often), sim(options, once)
    c = sim({**options, "random_walk": {"seed": 8, "sigma": 0.5}}, other)
    for _ in range(100):
        often.advance(0.0137)
        a.poll()
    once.advance(100 * 0.0137)
    other.advance(100 * 0.0137)
    assert a.poll().axes == b.poll().axes
    assert a.poll().axes != c.poll().axes


def test_random_walk_respects_channel_ranges() -> None:
    clock = ManualClock()
    device = sim({"mode": "random_walk", "random_walk": {"sigma": 5.0}}, clock)
    for _ in range(300):
        clock.advance(0.05)
        axes = device.poll().axes
        assert -1 <= axes["steer"] <= 1 and 0 <= axes["throttle"] <= 1 and 0 <= axes["brake"] <= 1


def drive_bicycle(device: SimInput, clock: ManualClock, seconds: float, start: tuple) -> list:
    """Kinematic bicycle in the loop with the sim driver; returns (x, y, yaw, v) per step."""
    x, y, yaw, v = start
    dt, wheelbase, max_steer = 0.02, 2.8, 0.6  # [s], [m], [rad] as in the options
    trace = []
    for _ in range(round(seconds / dt)):
        device.observe(x, y, yaw, v)
        axes = device.poll().axes
        accel = 3.0 * axes["throttle"] - 6.0 * axes["brake"]  # [m/s²] car-like pedals
        v = max(0.0, v + accel * dt)
        yaw += v / wheelbase * math.tan(axes["steer"] * max_steer) * dt
        x, y = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt
        clock.advance(dt)
        trace.append((x, y, yaw, v))
    return trace


def test_path_driver_follows_the_road_holds_speed_and_stops_at_the_end() -> None:
    straight = [(float(x), 0.0) for x in range(0, 101, 2)]
    clock = ManualClock()
    path = {"waypoints": straight, "target_speed_mps": 8.0, "stop_distance_m": 15.0}
    device = sim({"mode": "path", "path": path}, clock)
    trace = drive_bicycle(device, clock, 25.0, start=(0.0, 1.5, 0.0, 0.0))
    # After 8 s the 1.5 m start offset is gone to within 0.15 m (pure pursuit with a 6 m
    # look-ahead settles in ~2 look-ahead lengths) and the speed is within 0.5 m/s of 8.
    mid = [s for i, s in enumerate(trace) if 8.0 <= i * 0.02 <= 9.0]
    assert max(abs(y) for _, y, _, _ in mid) < 0.15
    assert all(abs(v - 8.0) < 0.5 for *_, v in mid)
    x_end, y_end, _, v_end = trace[-1]
    assert v_end < 0.3 and 90.0 < x_end < 104.0 and abs(y_end) < 0.2  # stopped at the end


def test_path_driver_takes_a_bend() -> None:
    radius = 30.0  # [m]
    arc = [(radius * math.sin(a / 40 * math.pi / 2), radius * (1 - math.cos(a / 40 * math.pi / 2)))
           for a in range(41)]  # fmt: skip
    waypoints = [(-40.0 + x, 0.0) for x in range(0, 40, 2)] + arc
    clock = ManualClock()
    path = {"waypoints": waypoints, "target_speed_mps": 6.0}
    device = sim({"mode": "path", "path": path}, clock)
    trace = drive_bicycle(device, clock, 20.0, start=(-40.0, 0.0, 0.0, 0.0))
    on_arc = [(x, y) for x, y, _, _ in trace if x > 5.0 and y < radius - 5]
    errors = [abs(math.hypot(x, y - radius) - radius) for x, y in on_arc]
    assert on_arc and max(errors) < 1.0  # pure pursuit cuts corners by ~l_d²/(2R) ≈ 0.6 m


def test_path_driver_is_hands_off_until_it_sees_the_vehicle() -> None:
    device = sim({"mode": "path", "path": {"waypoints": [(0, 0), (10, 0)]}}, ManualClock())
    assert device.poll().axes == {"steer": 0.0, "throttle": 0.0, "brake": 0.0}


class Flaky(InputDevice):
    def _poll(self, now: float):
        return {"a": float("nan"), "b": 3.0, "c": -7.0}, {}, {}


def test_poll_contract_clamps_and_guards_nan() -> None:
    device = Flaky(None, clock=lambda: 1.0)
    assert device.poll().axes == {"a": 0.0, "b": 1.0, "c": -1.0}
    assert device.invalid_samples == 1
    assert device.rumble(1, 1, 100) is False


# ---------------------------------------------------------------- pygame on SDL


def test_raw_channels_of_a_real_sdl_wheel(virtual_wheel) -> None:
    with hal.open_input({"backend": "pygame", "options": {"device": "Virtual"}}) as wheel:
        virtual_wheel.axis(0, -0.5)
        virtual_wheel.button(3, True)
        virtual_wheel.hat(0, 1 | 2)  # up-right
        state = wheel.poll()
    assert set(state.axes) == {"axis0", "axis1", "axis2", "axis3"}
    assert state.axes["axis0"] == pytest.approx(-0.5, abs=1e-4)
    assert state.buttons["button3"] and not state.buttons["button0"]
    assert state.hats == {"hat0": (1, 1)}


def test_named_mapping_with_pedals_and_deadzone(virtual_wheel) -> None:
    options = {
        "axes": {
            "steer": {"index": 0, "deadzone": 0.1},
            "throttle": {"index": 1, "invert": True, "unipolar": True},
        },
        "buttons": {"horn": 2},
        "hats": {"dpad": 0},
    }
    with hal.open_input({"backend": "pygame", "options": options}) as wheel:
        virtual_wheel.axis(0, 0.05)
        virtual_wheel.axis(1, -1.0)  # pedal fully pressed reads -1 on many wheels
        virtual_wheel.button(2, True)
        state = wheel.poll()
        assert state.axes["steer"] == 0.0
        assert state.axes["throttle"] == pytest.approx(1.0, abs=1e-4)
        virtual_wheel.axis(0, 0.55)
        virtual_wheel.axis(1, 1.0)
        state = wheel.poll()
        assert isinstance(wheel.rumble(0.5, 0.5, 50), bool)  # False: SDL's virtual has no motor
    assert state.axes["steer"] == pytest.approx(0.5, abs=1e-3)
    assert state.axes["throttle"] == pytest.approx(0.0, abs=1e-4)
    assert state.buttons == {"horn": True} and state.hats == {"dpad": (0, 0)}


def test_missing_joystick_and_bad_mapping_are_device_errors(virtual_wheel) -> None:
    with pytest.raises(DeviceError, match=r"no joystick matches 'G29'; SDL sees: 0: Virtual"):
        hal.open_input({"backend": "pygame", "options": {"device": "G29"}})
    with pytest.raises(DeviceError, match="index 9 but"):
        hal.open_input({"backend": "pygame", "options": {"axes": {"steer": {"index": 9}}}})


def test_map_axis() -> None:
    from carlaverse.hal.input.pygame_joystick import AxisMap, map_axis

    assert map_axis(1.0, AxisMap(index=0, invert=True)) == -1.0
    assert map_axis(0.0, AxisMap(index=0, unipolar=True)) == 0.5
    assert map_axis(-0.2, AxisMap(index=0, deadzone=0.2)) == 0.0
    assert map_axis(-0.6, AxisMap(index=0, deadzone=0.2)) == pytest.approx(-0.5)


# ---------------------------------------------------------------- keyboard


@pytest.fixture
def pygame_dummy(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pygame = pytest.importorskip("pygame")
    pygame.display.init()
    pygame.event.clear()
    return pygame


def key(pygame, kind: int, name: str) -> None:
    pygame.event.post(pygame.event.Event(kind, key=pygame.key.key_code(name)))


def test_keyboard_axes_ramp_while_held_and_fall_when_released(pygame_dummy) -> None:
    pg = pygame_dummy
    clock = ManualClock()
    options = {"buttons": {"horn": "h"}}
    with hal.open_input({"backend": "keyboard", "options": options}, clock=clock) as keys:
        key(pg, pg.KEYDOWN, "left")
        key(pg, pg.KEYDOWN, "up")
        key(pg, pg.KEYDOWN, "h")
        clock.advance(0.25)
        state = keys.poll()
        assert state.axes["steer"] == pytest.approx(0.5)  # left is +: 2 /s for 0.25 s
        assert state.axes["throttle"] == pytest.approx(1.0)  # 4 /s, capped at 1
        assert state.buttons == {"horn": True}
        key(pg, pg.KEYUP, "left")
        key(pg, pg.KEYUP, "h")
        clock.advance(0.1)
        state = keys.poll()
    assert state.axes["steer"] == pytest.approx(0.1)  # falls at 4 /s
    assert state.buttons == {"horn": False} and state.axes["brake"] == 0.0


@pytest.mark.parametrize(("arrow", "turns_left"), [("left", True), ("right", False)])
def test_keyboard_default_arrows_turn_the_car_their_way(pygame_dummy, arrow: str,
                                                        turns_left: bool) -> None:  # fmt: skip
    """The left arrow turns the car left. ISO 8855 (docs/protocol.md): yaw is counter-clockwise
    seen from above, so a car turning left has a positive yaw rate. The keyboard's default axes
    go through the desktop config's controls into the real drive loop."""
    from carlaverse_nodes.drive.config import load_drive_config
    from carlaverse_nodes.drive.vehicle_loop import DriveLoop

    from tests.drive.support import CONFIGS, DT

    pg = pygame_dummy
    config, vehicle = load_drive_config(CONFIGS / "drive-desktop.yaml")
    loop = DriveLoop(config, vehicle)
    loop.engage_drive()
    clock = ManualClock()
    with hal.open_input({"backend": "keyboard", "options": {}}, clock=clock) as keys:
        key(pg, pg.KEYDOWN, "up")  # 2 s of throttle to get rolling
        for _ in range(2000):
            clock.advance(DT)
            out = loop.step(DT, keys.poll())
        key(pg, pg.KEYUP, "up")
        key(pg, pg.KEYDOWN, arrow)
        for _ in range(1000):
            clock.advance(DT)
            out = loop.step(DT, keys.poll())
    assert out.speed_mps > 2.0
    assert (out.yaw_rate > 0.05) if turns_left else (out.yaw_rate < -0.05)


def test_keyboard_unknown_key_name_is_a_config_error(pygame_dummy) -> None:
    with pytest.raises(ConfigError, match=r"axes\.steer\.negative: unknown key name 'lefft'"):
        hal.open_input(
            {"backend": "keyboard", "options": {"axes": {"steer": {"positive": "right",
                                                                    "negative": "lefft"}}}}
        )  # fmt: skip


def test_sim_options_round_trip_through_convert() -> None:
    options = convert(PROFILE, SimInputOptions, "test")
    assert options.profile[1].buttons == {"horn": True}
