"""The paper's resistance equation and the calibrated table: golden values worked by hand."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.config import ConfigError
from carlaverse.hal.trainer.resistance_table import ResistanceTable, load_table
from carlaverse.physics.resistance import ResistanceParams, resistance_force, tailwind

P = ResistanceParams(rolling_coefficient=0.004, drag_coefficient=0.9, frontal_area_m2=0.5,
                     air_density_kgm3=1.2)  # fmt: skip
# ½·ρ·c_W·A = 0.5 · 1.2 · 0.9 · 0.5 = 0.27 kg/m


def test_flat_road_no_wind() -> None:
    # f_R·m·g = 0.004 · 90 · 9.81 = 3.5316 N; drag 0.27 · 5² = 6.75 N
    assert resistance_force(P, 90.0, 5.0, 0.0) == pytest.approx(10.2816, abs=1e-9)


def test_five_percent_climb_into_a_headwind() -> None:
    # θ = atan(0.05) = 0.0499584 rad: cos θ = 0.9987523, sin θ = 0.0499376
    # rolling 3.5316 · 0.9987523 = 3.5271938 N; slope 882.9 · 0.0499376 = 44.0899220 N
    # 8 m/s into a 2 m/s headwind: air speed 10 m/s, drag 0.27 · 100 = 27 N
    assert resistance_force(P, 90.0, 8.0, 5.0, tailwind_mps=-2.0) == pytest.approx(
        74.6171158, abs=1e-6
    )


def test_descent_and_a_strong_tailwind_push() -> None:
    # −5 %: slope −44.0899220 N; 5 m/s with a 10 m/s tailwind: air −5 m/s pushes, −6.75 N
    force = resistance_force(P, 90.0, 5.0, -5.0, tailwind_mps=10.0)
    assert force == pytest.approx(3.5271938 - 44.0899220 - 6.75, abs=1e-6)


def test_wind_projected_on_the_heading() -> None:
    # wind FROM 180° (blowing towards +x): a tailwind riding east, a headwind riding west
    # Bearings are compass bearings the wind comes FROM; heading 0 is east, π/2 north.
    assert tailwind(4.0, 270.0, 0.0) == pytest.approx(4.0)  # west wind, riding east
    assert tailwind(4.0, 270.0, math.pi) == pytest.approx(-4.0)  # west wind, riding west
    assert tailwind(4.0, 180.0, math.pi / 2) == pytest.approx(4.0)  # south wind, riding north
    assert tailwind(4.0, 0.0, 0.0) == pytest.approx(0.0, abs=1e-12)  # north wind: pure crosswind
    assert tailwind(4.0, 210.0, 0.0) == pytest.approx(2.0)  # 60° off the tail: 4·cos 60°


TABLE = ResistanceTable(speeds_mps=[0.0, 10.0], forces_n=[0.0, 100.0],
                        resistance_percent=[[0.0, 50.0], [10.0, 70.0]])  # fmt: skip


def test_bilinear_interpolation_golden_values() -> None:
    assert TABLE.percent(0.0, 0.0) == 0.0  # the corners come back exactly
    assert TABLE.percent(10.0, 100.0) == 70.0
    assert TABLE.percent(5.0, 50.0) == pytest.approx(32.5)  # (0+50+10+70)/4
    # (2.5 m/s, 25 N): along force 12.5 at 0 m/s and 25 at 10 m/s; a quarter across: 15.625
    assert TABLE.percent(2.5, 25.0) == pytest.approx(15.625)
    assert TABLE.percent(20.0, 200.0) == 70.0  # clamped at the table's edge
    assert TABLE.percent(-1.0, -50.0) == 0.0


@given(st.floats(-5, 20), st.floats(-50, 200))
def test_interpolation_stays_within_its_cell_corners(speed: float, force: float) -> None:
    value = TABLE.percent(speed, force)
    assert 0.0 <= value <= 70.0


def test_a_table_round_trips_through_yaml_and_rejects_a_bad_shape(tmp_path: Path) -> None:
    path = tmp_path / "table.yaml"
    TABLE.save(path)
    assert load_table(path) == TABLE
    path.write_text("speeds_mps: [0, 10]\nforces_n: [0, 100]\nresistance_percent: [[0, 1]]\n")
    with pytest.raises(ConfigError, match="2 rows × 2 columns"):
        load_table(path)
    path.write_text("speeds_mps: [0, 0]\nforces_n: [0, 100]\nresistance_percent: [[0,1],[0,1]]\n")
    with pytest.raises(ConfigError, match="strictly increasing"):
        load_table(path)
