"""The shipped drive configs load, and config errors name the file and field."""

from __future__ import annotations

import pytest
from carlaverse_nodes.drive.config import (
    DriveNodeConfig,
    input_configs,
    load_drive_config,
    node_settings,
)

from carlaverse.config import ConfigError
from tests.drive.support import CONFIGS


@pytest.mark.parametrize("name", ["drive-desktop", "drive-wheel", "drive-cabin"])
def test_shipped_configs_load_with_their_vehicle(name: str) -> None:
    config, vehicle = load_drive_config(CONFIGS / f"{name}.yaml")
    assert isinstance(config, DriveNodeConfig)
    assert vehicle.name == "compact-car"
    assert config.loop.rate_hz == 1000.0
    settings = node_settings(config, vehicle)
    assert settings.kind == "drive" and settings.mass_kg == vehicle.body.mass_kg
    assert settings.extent.length == vehicle.body.length_m


def test_cabin_merges_several_devices_and_overrides_the_gearbox() -> None:
    config, vehicle = load_drive_config(CONFIGS / "drive-cabin.yaml")
    assert [c.backend for c in input_configs(config)] == ["pygame"] * 3
    assert vehicle.transmission.mode == "manual"  # `gearbox: manual` over the vehicle file
    assert (config.ffb.backend, config.motion.backend) == ("udp", "udp")


def test_errors_name_the_file_and_field(tmp_path) -> None:
    path = tmp_path / "drive.yaml"
    path.write_text("motion_cueing:\n  pitch_limit_rad: -1\n")
    with pytest.raises(ConfigError, match=r"drive\.yaml.*motion_cueing\.pitch_limit_rad"):
        load_drive_config(path)
    path.write_text("vehicle: vehicles/no-such-car.yaml\n")
    with pytest.raises(ConfigError, match=r"no-such-car.*named by `vehicle:`"):
        load_drive_config(path)


def test_inline_vehicle(tmp_path) -> None:
    vehicle_text = (CONFIGS / "vehicles" / "van.yaml").read_text()
    inline = "vehicle:\n" + "".join(f"  {line}\n" for line in vehicle_text.splitlines())
    path = tmp_path / "drive.yaml"
    path.write_text(inline + "gearbox: manual\n")
    _, vehicle = load_drive_config(path)
    assert vehicle.name == "van" and vehicle.transmission.mode == "manual"
