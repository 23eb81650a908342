"""Controls: curve expressions, axis shaping, buttons' edges, and config errors."""

from __future__ import annotations

import pytest
from carlaverse_nodes.drive.controls import AxisMapping, Controls, ControlsConfig

from carlaverse.config import ConfigError, convert
from carlaverse.hal import InputState


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
    ("math.pow(x, 2)", 0.3, 0.09),
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
        throttle={"source": "gas", "curve": "x ** 2"}, brake={"source": "b", "invert": True}
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
