"""The scripted driver's route along the map, for drive and bike nodes whose `sim` input asks
for one (`path.map_lanes: car | bike`, as `--backend sim` sets).

On the first join that brings a map the node plans a route from where the node is (the spawn
the authority gave, `traffic.lane_route`) and hands it to its loop on the event queue; the
loop gives it to the `sim` input (`DriverRoute.apply`). The query waits on the authority, so
it runs off the step's thread, and until the route arrives the driver holds the brake. In a
session without a map, or with no lane of its kind near the node, the driver keeps its
configured waypoints.
"""

from __future__ import annotations

import logging
import threading
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import msgspec

from carlaverse import messages as m
from carlaverse.hal import InputConfig

log = logging.getLogger(__name__)

Where = Callable[[], tuple[float, float, float] | None]  # the loop's x, y [m], yaw [rad] now


@dataclass(frozen=True)
class DriverRoute:
    """What crosses to the loop: a route for its scripted driver, or a hold until one comes."""

    waypoints: list[tuple[float, float]] | None  # [m]; None: the configured waypoints
    loop_from: int | None = None  # after the last waypoint, go on at this one
    hold: bool = False  # brake until the next DriverRoute

    def apply(self, inputs: Iterable[Any]) -> None:
        """Hand it to every device that takes a route (the `sim` input)."""
        for device in inputs:
            if self.hold and hasattr(device, "hold"):
                device.hold()
            elif not self.hold and hasattr(device, "follow"):
                device.follow(self.waypoints, self.loop_from)


def map_lanes(config: InputConfig | None) -> tuple[str, int | None] | None:
    """(lane kind, seed) when `config` is a `sim` path driver that keeps to the map's lanes."""
    if config is None or config.backend != "sim":
        return None
    from carlaverse.hal.input.sim import SimInputOptions

    try:
        options = msgspec.convert(config.options, SimInputOptions)
    except msgspec.ValidationError:
        return None  # the loop's opening of the device says what is wrong, with the path
    path = options.path
    if options.mode != "path" or path is None or path.map_lanes == "none":
        return None
    return path.map_lanes, path.route_seed


class MapRoute:
    """Plans the route once per node (see the module docstring) and says how it went."""

    def __init__(self, lanes: str, seed: int | None, events: Any) -> None:
        self.lanes = lanes
        self.seed = seed
        self.events = events
        self._join = 0  # the join whose map was asked for
        self._planned = False
        self.outcome = "waiting for a join"

    def tend(self, client: Any, where: Where) -> None:
        """On a new join while no route is planned: hold the driver, fetch the map, plan."""
        if self._planned or client.joins == self._join:
            return
        first = self._join == 0
        self._join = client.joins
        if first:
            self.events.put(DriverRoute(None, hold=True))
        spawn = client.join_reply.spawn if first and client.join_reply else None
        start = (spawn.x, spawn.y, spawn.yaw) if spawn is not None else None
        seed = self.seed if self.seed is not None else zlib.crc32(client.node_id.encode())
        plan = threading.Thread(target=self._plan, args=(client, start, where, seed), daemon=True)
        plan.start()

    def _plan(self, client: Any, start: tuple[float, float, float] | None, where: Where,
              seed: int) -> None:  # fmt: skip
        from carlaverse.traffic.lane_route import plan_route

        raw = client.query("map")
        start = start or where()
        try:
            road_map = m.MAP.decode(raw) if raw is not None else None
        except m.MessageError as exc:
            log.warning("map unusable, the driver keeps its waypoints: %s", exc)
            road_map = None
        route = None
        if road_map is not None and start is not None:
            route = plan_route(road_map, self.lanes, *start, seed=seed)
        if route is None:
            self.outcome = "no map" if road_map is None else f"no {self.lanes} lane near {start}"
            self.events.put(DriverRoute(None))
            return
        self._planned = True
        shape = f"a {route.loop_m:.0f} m loop" if route.loop_from is not None else "open"
        self.outcome = f"{len(route.lanes)} lanes, {shape}"
        self.events.put(DriverRoute(route.waypoints, route.loop_from))

    def report(self) -> dict[str, Any]:
        return {"lanes": self.lanes, "route": self.outcome}
