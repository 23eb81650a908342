"""HMI configs: the shipped ones load; mistakes are reported with the file and field path."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.hmi.config import WIDGETS, default_config_name, load_hmi_config


@pytest.mark.parametrize("kind", ["drive", "bike"])
def test_shipped_configs_load_with_known_widgets(kind: str) -> None:
    loaded = load_hmi_config(default_config_name(kind))
    assert loaded.pages_dir is None
    assert loaded.config.hmi.rate_hz >= 30
    assert loaded.config.hmi.home in loaded.config.layouts
    for layout in loaded.config.layouts.values():
        assert layout.widgets and all(w.widget in WIDGETS for w in layout.widgets)


def test_an_unknown_widget_names_the_field_path(tmp_path: Path) -> None:
    config = tmp_path / "hmi.yaml"
    config.write_text("layouts:\n  dash:\n    widgets:\n      - {widget: speedo}\n")
    where = r"\$\.layouts\[\.\.\.\]\.widgets\[0\]"  # msgspec elides the dict key
    with pytest.raises(ConfigError, match=r"unknown widget 'speedo'.*" + where):
        load_hmi_config(str(config))


def test_units_and_rate_are_checked(tmp_path: Path) -> None:
    config = tmp_path / "hmi.yaml"
    config.write_text("hmi: {units: furlongs}\n")
    with pytest.raises(ConfigError, match=r"\$\.hmi\.units"):
        load_hmi_config(str(config))
    config.write_text("hmi: {rate_hz: 10}\n")  # below the 30 Hz the dashboard needs
    with pytest.raises(ConfigError, match=r">= 30.*\$\.hmi\.rate_hz"):
        load_hmi_config(str(config))


def test_pages_dir_is_relative_to_the_config_and_must_exist(tmp_path: Path) -> None:
    config = tmp_path / "hmi.yaml"
    config.write_text("hmi: {pages_dir: my-pages}\n")
    with pytest.raises(ConfigError, match=r"hmi\.pages_dir: no such folder"):
        load_hmi_config(str(config))
    (tmp_path / "my-pages").mkdir()
    assert load_hmi_config(str(config)).pages_dir == tmp_path / "my-pages"
