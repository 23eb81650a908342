"""The road's grade under the bike, from the scenario the authority runs.

The map carries no elevation, so a scenario declares grades (`carlaverse.traffic.scenario.
Grades`): tilted areas, then a default. `RoadGrade.at(x, y, yaw)` answers for one position and
heading; None means the scenario says nothing there and the node's `road.grade_percent`
applies. The areas' corners and bounding boxes are precomputed, so a lookup at the node's step
rate (~50 Hz) costs a box test per area and a polygon test only for the boxes that hold the
point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.config import ConfigError, convert, parse_yaml
from carlaverse.geometry import inside_polygon
from carlaverse.traffic.scenario import GradeArea, Grades

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class _Tilt:
    outline: tuple[Point, ...]  # [m] map frame
    box: tuple[float, float, float, float]  # [m] xmin, ymin, xmax, ymax
    grade_percent: float  # [%] going uphill
    uphill_rad: float  # [rad] counter-clockwise from east

    @classmethod
    def of(cls, area: GradeArea) -> _Tilt:
        xs, ys = [p[0] for p in area.polygon], [p[1] for p in area.polygon]
        box = (min(xs), min(ys), max(xs), max(ys))
        uphill = math.radians(area.uphill_yaw_deg)
        return cls(tuple(area.polygon), box, area.grade_percent, uphill)

    def holds(self, x: float, y: float) -> bool:
        x0, y0, x1, y1 = self.box
        return x0 <= x <= x1 and y0 <= y <= y1 and inside_polygon(self.outline, x, y)

    def felt(self, yaw_rad: float) -> float:
        """The grade [%] along the heading: a plane's slope is linear in the direction."""
        return self.grade_percent * math.cos(yaw_rad - self.uphill_rad)


class RoadGrade:
    """Grade lookup over a scenario's `grades:` block."""

    def __init__(self, grades: Grades) -> None:
        self.tilts = [_Tilt.of(area) for area in grades.areas]
        self.default_percent = grades.default_percent

    @classmethod
    def from_scenario_yaml(cls, text: str, source: str = "authority/scenario") -> RoadGrade:
        """Read only the `grades:` block, so the rest of a newer scenario cannot stop it.

        Raises ConfigError naming the source and the field path of a bad grade.
        """
        data = parse_yaml(text, source)
        if not isinstance(data, dict):
            raise ConfigError(source, "a scenario is a mapping of sections")
        return cls(convert(data.get("grades") or {}, Grades, source))

    def at(self, x: float, y: float, yaw_rad: float) -> float | None:
        """The grade [%] felt at (x, y) [m] heading yaw [rad]; None where the scenario is silent."""
        for tilt in self.tilts:
            if tilt.holds(x, y):
                return tilt.felt(yaw_rad)
        return self.default_percent
