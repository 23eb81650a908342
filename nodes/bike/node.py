"""The bike node as a `carlaverse join` kind: the fabric side of CycloCARLA.

This process owns the fabric; the physics + haptics loop runs in a child process
(`loop_process`). The pose publisher reads the loop's shared state at the pose rate; the
node's step forwards impulses to the loop's queue and hands it the clock offset, the spawn
pose, the authority's wind, and the road's grade under the bike (looked up here, at the
step rate, in the scenario's `grades:`; the node config's `road.grade_percent` where the
scenario says nothing). A scripted rider that keeps to the map's lanes (`--backend sim`) gets
its route along them on the loop's queue (`map_route`).
"""

from __future__ import annotations

import functools
import logging
import threading
from typing import Any

import msgspec
from carlaverse_nodes.bike.config import BikeNodeConfig, node_settings, resolve_table
from carlaverse_nodes.bike.hmi_bridge import BikeHmiBridge
from carlaverse_nodes.bike.loop_process import BikeLoopSpec, run_bike_loop
from carlaverse_nodes.bike.road_grade import RoadGrade
from carlaverse_nodes.bike.shared_state import CONTROL, STATE
from carlaverse_nodes.loop_host import LoopHost
from carlaverse_nodes.map_route import MapRoute, map_lanes

from carlaverse import messages as m
from carlaverse.config import ConfigError
from carlaverse.hal import FfbConfig, InputConfig, TrainerConfig
from carlaverse.hal.input.pursuit import scripted_route
from carlaverse.transport.node_client import NodeClient

log = logging.getLogger(__name__)


class BikeNode(LoopHost):
    name = "bike"
    config_type = BikeNodeConfig

    def __init__(self, config: BikeNodeConfig) -> None:
        super().__init__(STATE, CONTROL, "bike loop")
        self.config = config
        self.table = resolve_table(config)
        self.node_settings = node_settings(config)
        self._forwarded = 0
        self._grades: RoadGrade | None = None  # the scenario's, once fetched
        self._grades_join = 0  # the join whose scenario was asked for
        self._hmi: BikeHmiBridge | None = None
        self._route: MapRoute | None = None  # the scripted rider's, along the map's lanes

    @classmethod
    def with_backend(cls, config: BikeNodeConfig, backend: str) -> BikeNodeConfig:
        """Every device simulated: a rider on the simulated FTMS trainer keeps to the map's
        bike lanes or the right edge of its roads, and laps a block where there is no map."""
        if backend != "sim":
            raise ValueError(f"--backend {backend!r}: the bike node can force only 'sim'")
        route = {"waypoints": scripted_route(), "wheelbase_m": config.bicycle.wheelbase_m,
                 "max_steer_rad": config.bicycle.max_steer_rad, "lookahead_m": 5.0,
                 "map_lanes": "bike"}  # fmt: skip
        rider = InputConfig(backend="sim", options={"axes": ["steer"], "mode": "path",
                                                     "path": route})  # fmt: skip
        return msgspec.structs.replace(
            config, input=rider, ffb=FfbConfig(backend="sim"),
            trainer=TrainerConfig(backend="ftms_sim"), speed_source="trainer",
        )  # fmt: skip

    def start(self, session: str, node_id: str, offset: float) -> None:
        spec = functools.partial(BikeLoopSpec, self.config, self.table)
        grade = self.config.road.grade_percent
        self._start_loop(
            session, node_id, run_bike_loop, spec, clock_offset=offset, grade_percent=grade
        )
        lanes = map_lanes(self.config.input)
        if lanes is not None:
            self._route = MapRoute(*lanes, self._events)

    def hmi_bridge(self) -> BikeHmiBridge:
        """The web HMI's view of this bike (carlaverse join bike --hmi PORT)."""
        self._hmi = BikeHmiBridge(self.node_settings, lambda: self._state)
        return self._hmi

    def _pose_extras(self, s: Any) -> dict[str, float]:
        return {"roll": float(s["roll"]), "wz": float(s["yaw_rate"])}  # roll: ISO 8855

    def step(self, client: NodeClient, now: float) -> None:
        weather = client.world.weather
        wind = (weather.wind_speed_mps, weather.wind_direction_deg) if weather else (0.0, 0.0)
        self._tend_loop(client, wind_speed_mps=wind[0], wind_from_deg=wind[1])
        if self._route is not None:
            self._route.tend(client, self._loop_pose)
        if self._hmi is not None:
            self._hmi.clock_offset = client.clock.offset
        self._follow_grade(client)
        self._forwarded += self._forward(client.impulses)
        if not self._process.is_alive():
            raise RuntimeError(f"the bike loop process died (exit {self._process.exitcode})")

    def _follow_grade(self, client: NodeClient) -> None:
        """Ask each authority joined for its scenario's grades; tell the loop the grade here."""
        if client.joins != self._grades_join:
            self._grades_join = client.joins
            fetch = threading.Thread(target=self._fetch_grades, args=(client,), daemon=True)
            fetch.start()  # the query waits on the authority: never in the step
        assert self._control is not None
        self._control.write_fields(grade_percent=self._grade_here())

    def _fetch_grades(self, client: NodeClient) -> None:
        raw = client.query("scenario")
        if raw is None:  # no scenario (`--scenario none`) or no answer: nothing changes
            return
        try:
            self._grades = RoadGrade.from_scenario_yaml(m.SCENARIO.decode(raw).yaml)
        except (m.MessageError, ConfigError) as exc:
            log.warning("scenario grades unusable, riding road.grade_percent instead: %s", exc)

    def _grade_here(self) -> float:
        """[%] at the bike's position and heading; the config's where the scenario is silent."""
        fallback = self.config.road.grade_percent
        assert self._state is not None
        s = self._state.read_latest()
        if self._grades is None or not s["running"]:
            return fallback
        grade = self._grades.at(float(s["x"]), float(s["y"]), float(s["yaw"]))
        return fallback if grade is None else grade

    def close(self) -> None:
        self._stop_loop()

    def report(self) -> dict[str, Any]:
        areas = len(self._grades.tilts) if self._grades is not None else None
        route = self._route.report() if self._route is not None else None
        return {"loop": self._loop_summary, "events_forwarded": self._forwarded,
                "scenario_grade_areas": areas, "map_route": route}  # fmt: skip
