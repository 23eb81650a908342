"""Traffic: the engine that moves NPC vehicles and pedestrians, its maps and its scenarios.

`engine` is the seam (a `TrafficEngine` protocol, so a CARLA bridge can be added later);
`sumo_engine` implements it with Eclipse SUMO in-process through `libsumo`. Nothing here
imports libsumo at import time: only constructing a `SumoEngine` does.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from carlaverse.authority.traffic_domain import TrafficDomain


def load_domain(
    scenario_name_or_path: str | Path,
    seed_override: int | None = None,
    *,
    cache_dir: Path | None = None,
) -> TrafficDomain:
    """The authority's global domain for a scenario (see `carlaverse.authority.traffic_domain`)."""
    from carlaverse.authority.traffic_domain import load_domain as load

    return load(scenario_name_or_path, seed_override, cache_dir=cache_dir)
