"""The HMI's YAML: server settings and each page's layout (which widgets, where, in what units).

    hmi:
      rate_hz: 60              # telemetry frames per second to every page
      units: km/h              # or mph
      pages_dir: my-pages      # extra pages (HTML/JS), relative to this file; optional
      home: dashboard          # the page the node's printed URL opens (/ lists them all)
    layouts:
      dashboard:
        title: Dashboard
        columns: 4             # a CSS grid of this many equal columns
        widgets:
          - {widget: speedometer, column: 1, row: 1, width: 2, height: 2}
          - {widget: gear, column: 3, row: 1}

A page finds its layout by its own name (`/api/layout/<page>`); a page dropped into
`pages_dir` may have one here or draw itself. Shipped configs: `hmi/drive.yaml`,
`hmi/bike.yaml` (configs/hmi/), chosen by node kind unless `--hmi-config` names another.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import msgspec

from carlaverse.config import ConfigError, StrictStruct, load_config, resolve_path
from carlaverse.patterns import whole_ascii

Cell = Annotated[int, msgspec.Meta(ge=1, le=24)]  # a grid line or span, in cells
PAGE_NAME = whole_ascii(r"[a-z0-9][a-z0-9_-]{0,39}")  # whole text: `$` let "dash\n" in
WIDGETS = (
    "speedometer", "tachometer", "gear", "indicators", "lights", "adas", "warnings",
    "speed", "power", "cadence", "grade", "lights_panel", "gear_panel", "cruise_panel",
    "indicator_panel",
)  # fmt: skip


class WidgetPlace(StrictStruct):
    """One widget on a page's grid."""

    widget: str  # one of WIDGETS
    column: Cell = 1
    row: Cell = 1
    width: Cell = 1  # [cells]
    height: Cell = 1  # [cells]
    label: str = ""  # shown instead of the widget's own title

    def __post_init__(self) -> None:
        if self.widget not in WIDGETS:
            raise ValueError(f"unknown widget {self.widget!r}; known: {', '.join(WIDGETS)}")


class Layout(StrictStruct):
    title: str = ""
    columns: Cell = 4
    units: Literal["km/h", "mph"] | None = None  # None: the `hmi.units` default
    widgets: list[WidgetPlace] = []


class HmiSettings(StrictStruct):
    rate_hz: Annotated[float, msgspec.Meta(ge=30, le=240)] = 60.0  # telemetry frames [1/s]
    units: Literal["km/h", "mph"] = "km/h"
    pages_dir: str | None = None  # relative to the config file
    home: str = "dashboard"


class HmiConfig(StrictStruct):
    hmi: HmiSettings = HmiSettings()
    layouts: dict[str, Layout] = {}

    def __post_init__(self) -> None:
        bad = [name for name in self.layouts if not PAGE_NAME.match(name)]
        if bad:
            raise ValueError(f"layout name(s) {bad}: use lower-case letters, digits, - and _")


class LoadedHmiConfig(msgspec.Struct, frozen=True):
    """A decoded HMI config and the folder of extra pages it names (resolved, checked)."""

    config: HmiConfig
    source: str
    pages_dir: Path | None


def default_config_name(kind: str) -> str:
    """The shipped HMI config of a node kind, e.g. `hmi/drive.yaml`."""
    return f"hmi/{kind}.yaml"


def questionnaire_only_config() -> LoadedHmiConfig:
    """The HMI of a node kind without pages of its own: its home is the questionnaire page."""
    config = HmiConfig(hmi=HmiSettings(home="questionnaire"))
    return LoadedHmiConfig(config, "built-in (questionnaires only)", None)


def load_hmi_config(name: str) -> LoadedHmiConfig:
    """Load an HMI config (path or shipped name) and resolve its `hmi.pages_dir`."""
    path = resolve_path(name)
    config = load_config(path, HmiConfig)
    pages_dir = None
    if config.hmi.pages_dir is not None:
        pages_dir = (path.parent / Path(config.hmi.pages_dir).expanduser()).resolve()
        if not pages_dir.is_dir():
            raise ConfigError(str(path), f"hmi.pages_dir: no such folder {pages_dir}")
    return LoadedHmiConfig(config, str(path), pages_dir)
