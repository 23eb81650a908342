"""The shipped vehicles, loaded from configs/vehicles/ for the physics and drive tests."""

from __future__ import annotations

from pathlib import Path

from carlaverse.physics.params import VehicleParams, load_vehicle

VEHICLES_DIR = Path(__file__).resolve().parents[2] / "configs" / "vehicles"
SHIPPED_VEHICLES = ("compact-car", "van")


def shipped_vehicle(name: str) -> VehicleParams:
    return load_vehicle(VEHICLES_DIR / f"{name}.yaml")
