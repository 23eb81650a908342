"""Controls: curve expressions, axis shaping, buttons' edges, and config errors."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from carlaverse_nodes.drive.config import load_drive_config
from carlaverse_nodes.drive.controls import AxisMapping, Controls, ControlsConfig
from carlaverse_nodes.drive.vehicle_loop import DriveLoop

from carlaverse.config import ConfigError, convert
from carlaverse.hal import InputState
from tests.drive.support import keys, run


def state(axes: dict[str, float] | None = None, buttons: dict[str, bool] | None = None,
          hats: dict[str, tuple[int, int]] | None = None) -> InputState:  # fmt: skip
    return InputState(0.0, axes or {}, buttons or {}, hats or {})


def controls(**sections: object) -> Controls:
    return Controls(convert(sections, ControlsConfig, "test"))


# The paper's sensitivity curve y = sgn(x)·|x|^γ (eq. `inputmapping`) and its `math.pow`
# example, with hand-computed values: 0.5^1.8 = e^(1.8·ln 0.5) = e^(−1.247665) = 0.287175.
CURVES = [
    ("sgn(x) * abs(x) ** 1.8", 0.5, 0.287175),
    ("sgn(x) * abs(x) ** 1.8", -0.5, -0.287175),
    ("sgn(x) * abs(x) ** 1.8", 1.0, 1.0),
    ("sgn(x) * abs(x) ** 1.8", 0.0, 0.0),
    ("sgn(x) * abs(x) ** 1.8", -1.0, -1.0),
    ("sgn(x) * math.pow(abs(x), 2)", -0.3, -0.09),  # the paper's example, made odd
    ("x", -0.42, -0.42),
    ("clamp(2 * x, -1, 1)", 0.7, 1.0),  # a steeper, saturating steer
]


@pytest.mark.parametrize(("curve", "x", "y"), CURVES)
def test_curve_expressions_on_the_steering_axis(curve: str, x: float, y: float) -> None:
    c = controls(steer={"source": "wheel", "curve": curve})
    # 1e-6: the hand values are rounded to six decimals.
    assert c.read(state({"wheel": x})).steer == pytest.approx(y, abs=1e-6)


def test_pedal_curve_invert_and_clamp() -> None:
    c = controls(
        throttle={"source": "gas", "curve": "math.pow(x, 2)"},
        brake={"source": "b", "invert": True},
    )
    cmd = c.read(state({"gas": 0.5, "b": -0.8}))
    assert cmd.throttle == pytest.approx(0.25)
    assert cmd.brake == pytest.approx(0.8)
    assert c.read(state({"gas": -0.5, "b": 0.8})).throttle == 0.0  # pedals never go negative
    assert c.read(state({"gas": -0.5, "b": 0.8})).brake == 0.0


def test_deadzone_is_rescaled_to_full_travel() -> None:
    c = controls(steer={"source": "s", "deadzone": 0.1})
    assert c.read(state({"s": 0.05})).steer == 0.0
    assert c.read(state({"s": -0.55})).steer == pytest.approx(-0.5)
    assert c.read(state({"s": 1.0})).steer == pytest.approx(1.0)


def test_combined_pedal_axis_split_in_halves() -> None:
    c = controls(
        throttle={"source": "pedals", "half": "positive"},
        brake={"source": "pedals", "half": "negative"},
    )
    cmd = c.read(state({"pedals": -0.6}))
    assert (cmd.throttle, cmd.brake) == (0.0, pytest.approx(0.6))


def test_missing_channels_read_as_released() -> None:
    cmd = controls().read(state())
    assert (cmd.steer, cmd.throttle, cmd.brake, cmd.clutch) == (0.0, 0.0, 0.0, 0.0)


def test_buttons_and_hats_give_rising_edges_and_levels() -> None:
    c = controls(buttons={"hazard": "b3", "indicator_left": ["b4", "hat:dpad:left"]})
    first = c.read(state(buttons={"b3": True}, hats={"dpad": (-1, 0)}))
    assert first.pressed == {"hazard", "indicator_left"}
    held = c.read(state(buttons={"b3": True}, hats={"dpad": (-1, 0)}))
    assert held.pressed == frozenset() and held.held == {"hazard", "indicator_left"}
    c.read(state())
    again = c.read(state(buttons={"b4": True}))
    assert again.pressed == {"indicator_left"}


def test_a_failing_curve_is_refused_at_load_or_counted_at_run_time() -> None:
    # log(0) fails on the pedal's rest position: found when the config loads.
    with pytest.raises(ConfigError, match=r"controls\.throttle\.curve"):
        controls(throttle={"source": "t", "curve": "log(x)"})
    # A pole between the load-time sample points (every 0.05) slips through; at run time
    # the failure is counted and the linear value used — the loop never sees an exception.
    c = controls(throttle={"source": "t", "curve": "0.1 / (x - 0.125) + 1"})
    assert c.read(state({"t": 0.125})).throttle == pytest.approx(0.125)
    assert c.curve_errors == 1


@pytest.mark.parametrize(
    ("sections", "message"),
    [
        ({"buttons": {"indicatr_left": "b1"}}, "unknown action"),
        ({"buttons": {"hazard": "hat:dpad:sideways"}}, "not a hat source"),
        ({"steer": {"source": "s", "curve": "__import__('os')"}}, "not allowed"),
        ({"steer": {"source": "s", "deadzone": 1.5}}, "<"),
        ({"steer": {"source": "s", "gain": 2}}, "unknown field"),
    ],
)
def test_config_errors_name_the_field(sections: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        convert(sections, ControlsConfig, "drive.yaml")


def test_axis_mapping_defaults() -> None:
    assert AxisMapping(source="x").curve == "x"


# Steering curves (issue 40.5). The physical statement: full left at the wheel turns the road
# wheels left and full right turns them right, by as much (ISO 8855: a road-wheel angle and a
# yaw rate > 0 are to the left; a steer command of +1 is full left, `DriverCommand.steer`). A curve
# that is not odd breaks it: the paper's `math.pow(x, 2)` gives (−1)² = 1² = 1, full left
# both ways. The config decoder must refuse those; every curve it accepts must keep the signs.
STEER_CURVES = [
    "x", "sgn(x) * abs(x) ** 1.3", "math.tanh(3 * x) / math.tanh(3)", "deadzone(x, 0.1)",
    "clamp(2 * x, -1, 1)", "-x",  # -x: a mirrored wheel, still opposite ways
    "math.pow(x, 2)", "pow(x, 2)", "x ** 2", "abs(x)", "x + 0.05", "x if x > 0 else 0.5 * x",
]  # fmt: skip
NOT_ODD = {"math.pow(x, 2)", "pow(x, 2)", "x ** 2", "abs(x)", "x + 0.05",
           "x if x > 0 else 0.5 * x"}  # fmt: skip


def _steer_after(loop: DriveLoop, steer: float) -> tuple[float, float]:
    """Road-wheel angle [rad] and yaw rate [rad/s] after 0.5 s of `steer` at 10 m/s."""
    loop.place(0.0, 0.0, 0.0, 10.0)
    out = run(loop, 0.5, keys(steer, 0.2))
    return out.steer_rad, out.yaw_rate


@pytest.mark.parametrize("curve", STEER_CURVES)
def test_full_left_and_full_right_steer_opposite_ways_or_the_curve_is_refused(
    curve: str, tmp_path: Path
) -> None:
    path = tmp_path / "drive.yaml"
    path.write_text(yaml.safe_dump({"controls": {"steer": {"source": "steer", "curve": curve}}}))
    try:
        config, vehicle = load_drive_config(path)
    except ConfigError as exc:
        message = str(exc)
        assert "controls.steer.curve" in message and "must be odd" in message, message
        assert "\n" not in message
        assert curve in NOT_ODD, f"{curve!r} is odd yet refused: {message}"
        return
    assert curve not in NOT_ODD, f"{curve!r} was accepted on the steering axis"
    left, right = DriveLoop(config, vehicle), DriveLoop(config, vehicle)
    for loop in (left, right):
        loop.engage_drive()
    left_angle, left_yaw = _steer_after(left, 1.0)
    right_angle, right_yaw = _steer_after(right, -1.0)
    assert left_angle * right_angle < 0 and left_yaw * right_yaw < 0
    # and by as much: mirrored inputs on a car symmetric about its x axis mirror exactly
    assert left_angle == pytest.approx(-right_angle, rel=1e-6)
    assert left_yaw == pytest.approx(-right_yaw, rel=1e-6)


def test_a_curve_that_is_not_odd_is_refused_naming_the_values() -> None:
    # (−0.5)² = 0.25 = 0.5²: both halves of the wheel steer the same way. The worst sample is
    # at full lock: (±1)² = 1.
    with pytest.raises(ConfigError) as err:
        controls(steer={"source": "s", "curve": "pow(x, 2)"})
    assert str(err.value) == (
        "test: controls.steer.curve: 'pow(x, 2)' must be odd (f(-x) = -f(x)) so that left and "
        "right steer opposite ways by as much; got f(-1)=1, f(1)=1; shape the magnitude and "
        "keep the sign, e.g. sgn(x) * pow(abs(x), 2)"
    )
    # On a pedal the same curve is the paper's progressive brake: allowed.
    assert controls(brake={"source": "b", "curve": "pow(x, 2)"}).read(
        state({"b": 0.5})
    ).brake == pytest.approx(0.25)
