"""Fixtures for the physics tests."""

from __future__ import annotations

import pytest

from carlaverse.physics.params import VehicleParams
from tests.physics.vehicles import shipped_vehicle


@pytest.fixture
def compact_car() -> VehicleParams:
    return shipped_vehicle("compact-car")
