"""The drive node as a `carlaverse join` kind: the fabric side of DrivoCARLA.

This process owns the fabric; the control loop runs in a child process (`loop_process`).
The pose publisher reads the loop's shared state at the pose rate; the node's step forwards
impulses and overrides to the loop's queue, hands it the session-clock offset and the spawn
pose, and publishes the ego state when lights, indicator, gear or ADAS change. On each join
it asks the authority for its scenario and hands the loop the `surface:` block (roughness,
speed bumps, kerbs, potholes) on the same queue. A scripted driver that keeps to the map's
lanes (`--backend sim`) gets its route along them the same way (`map_route`).
"""

from __future__ import annotations

import functools
import logging
import threading
from typing import Any

import msgspec
from carlaverse_nodes.drive.config import (
    DriveNodeConfig,
    input_configs,
    node_settings,
    resolve_vehicle,
)
from carlaverse_nodes.drive.hmi_bridge import DriveHmiBridge
from carlaverse_nodes.drive.loop_process import LoopSpec, run_loop
from carlaverse_nodes.drive.shared_state import CONTROL, INDICATORS, STATE
from carlaverse_nodes.loop_host import LoopHost
from carlaverse_nodes.map_route import MapRoute, map_lanes

from carlaverse import messages as m
from carlaverse.config import ConfigError
from carlaverse.hal import FfbConfig, InputConfig, MotionConfig
from carlaverse.hal.input.pursuit import scripted_route
from carlaverse.messages import EgoState
from carlaverse.physics.params import VehicleParams
from carlaverse.physics.road_surface import RoadSurface
from carlaverse.transport.node_client import NodeClient

log = logging.getLogger(__name__)


class DriveNode(LoopHost):
    name = "drive"
    config_type = DriveNodeConfig

    def __init__(self, config: DriveNodeConfig) -> None:
        super().__init__(STATE, CONTROL, "control loop")
        self.config = config
        self.vehicle: VehicleParams = resolve_vehicle(config)
        self.node_settings = node_settings(config, self.vehicle)
        self._last_state: tuple[int, int, int, bool] | None = None
        self._forwarded = 0
        self._hmi: DriveHmiBridge | None = None
        self._surface_join = 0  # the join whose scenario was asked for
        self._route: MapRoute | None = None  # the scripted driver's, along the map's lanes

    @classmethod
    def with_backend(cls, config: DriveNodeConfig, backend: str) -> DriveNodeConfig:
        """Every device on `backend`; for `sim`, a scripted driver keeps to the map's car
        lanes, slowing for bends (3 m/s² sideways), and laps a block where there is no map."""
        if backend != "sim":
            raise ValueError(f"--backend {backend!r}: the drive node can force only 'sim'")
        route = {
            "waypoints": scripted_route(),
            "target_speed_mps": 12.0,
            "wheelbase_m": self_wheelbase(config),
            "max_steer_rad": 0.593,
            "corner_accel_mps2": 3.0,
            "lookahead_time_s": 0.8,
            "map_lanes": "car",
        }
        driver = InputConfig(backend="sim", options={"mode": "path", "path": route})
        return msgspec.structs.replace(
            config, input=driver, ffb=FfbConfig(backend="sim"), motion=MotionConfig(backend="sim")
        )

    # ------------------------------------------------------------ lifecycle

    def start(self, session: str, node_id: str, offset: float) -> None:
        """Create the shared blocks and start the control process."""
        spec = functools.partial(LoopSpec, self.config, self.vehicle)
        self._start_loop(session, node_id, run_loop, spec, clock_offset=offset)
        lanes = next(filter(None, map(map_lanes, input_configs(self.config))), None)
        if lanes is not None:
            self._route = MapRoute(*lanes, self._events)

    def hmi_bridge(self) -> DriveHmiBridge:
        """The web HMI's view of this car (carlaverse join drive --hmi PORT)."""
        self._hmi = DriveHmiBridge(self.node_settings, self.vehicle, lambda: self._state)
        return self._hmi

    def _pose_extras(self, s: Any) -> dict[str, float]:
        return {"wz": float(s["yaw_rate"])}

    def step(self, client: NodeClient, now: float) -> None:
        self._tend_loop(client)
        if self._route is not None:
            self._route.tend(client, self._loop_pose)
        self._follow_surface(client)
        assert self._state is not None
        self._forwarded += self._forward(client.impulses) + self._forward(client.overrides)
        state = self._state.read_latest()
        if self._hmi is not None:
            self._hmi.clock_offset = client.clock.offset
            self._forwarded += self._hmi.forward(self._events, now, float(state["speed_mps"]))
        self._publish_state(client, state)
        if not self._process.is_alive():
            raise RuntimeError(f"the control loop process died (exit {self._process.exitcode})")

    def _follow_surface(self, client: NodeClient) -> None:
        """Ask each authority joined for its scenario's road surface (off the step's thread:
        the query waits on the authority); the loop gets it on its event queue."""
        if client.joins != self._surface_join:
            self._surface_join = client.joins
            threading.Thread(target=self._fetch_surface, args=(client,), daemon=True).start()

    def _fetch_surface(self, client: NodeClient) -> None:
        raw = client.query("scenario")
        if raw is None:  # no scenario (`--scenario none`) or no answer: the config's road
            return
        try:
            surface = RoadSurface.from_scenario_yaml(m.SCENARIO.decode(raw).yaml)
        except (m.MessageError, ConfigError) as exc:
            log.warning("scenario surface unusable, driving the config's road instead: %s", exc)
            return
        self._events.put(surface)  # the loop reports it as `surface_features`

    def _publish_state(self, client: NodeClient, s: Any) -> None:
        if not s["running"]:
            return
        key = (int(s["lights"]), int(s["indicator"]), int(s["gear"]), bool(s["adas_active"]))
        if key == self._last_state:
            return
        self._last_state = key
        client.publish_state(
            EgoState(
                0,
                float(s["t"]),
                key[0],
                INDICATORS[key[1]],
                key[2],
                float(s["speed_mps"]),
                "adas" if key[3] else "",
            )
        )

    def close(self) -> None:
        self._stop_loop()

    def report(self) -> dict[str, Any]:
        route = self._route.report() if self._route is not None else None
        return {"loop": self._loop_summary, "events_forwarded": self._forwarded,
                "map_route": route}  # fmt: skip


def self_wheelbase(config: DriveNodeConfig) -> float:
    """The pure-pursuit driver needs the car's wheelbase [m]."""
    return float(resolve_vehicle(config).body.wheelbase_m)
