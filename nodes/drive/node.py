"""The drive node as a `carlaverse join` kind: the fabric side of DrivoCARLA.

This process owns the fabric; the control loop runs in a child process (`loop_process`).
The pose publisher reads the loop's shared state at the pose rate; the node's step forwards
impulses and overrides to the loop's queue, hands it the session-clock offset and the spawn
pose, and publishes the ego state when lights, indicator, gear or ADAS change.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
from typing import Any

import msgspec
from carlaverse_nodes.drive.config import DriveNodeConfig, node_settings, resolve_vehicle
from carlaverse_nodes.drive.hmi_bridge import DriveHmiBridge
from carlaverse_nodes.drive.loop_process import LoopSpec, run_loop
from carlaverse_nodes.drive.shared_state import CONTROL, INDICATORS, STATE

from carlaverse.fabric.node_client import NodeClient, PoseSource
from carlaverse.hal import FfbConfig, InputConfig, MotionConfig
from carlaverse.hal.input.pursuit import scripted_route
from carlaverse.messages import EgoState, Pose
from carlaverse.physics.params import VehicleParams
from carlaverse.realtime import stop_loop_process
from carlaverse.render.live import OwnPoseBlock
from carlaverse.shm import SharedBlock, block_name

log = logging.getLogger(__name__)


class DriveNode:
    name = "drive"
    config_type = DriveNodeConfig

    def __init__(self, config: DriveNodeConfig) -> None:
        self.config = config
        self.vehicle: VehicleParams = resolve_vehicle(config)
        self.node_settings = node_settings(config, self.vehicle)
        self._ctx = mp.get_context("spawn")
        self._state: SharedBlock | None = None
        self._control: SharedBlock | None = None
        self._process: Any = None
        self._events: Any = None
        self._results: Any = None
        self._stop: Any = None
        self._last_state: tuple[int, int, int, bool] | None = None
        self._spawn_seq = 0
        self._joins_seen = 0
        self._loop_summary: dict[str, Any] = {}
        self._forwarded = 0
        self._hmi: DriveHmiBridge | None = None

    @classmethod
    def with_backend(cls, config: DriveNodeConfig, backend: str) -> DriveNodeConfig:
        """Every device on `backend`; for `sim`, a scripted driver laps a block."""
        if backend != "sim":
            raise ValueError(f"--backend {backend!r}: the drive node can force only 'sim'")
        route = {
            "waypoints": scripted_route(),
            "target_speed_mps": 12.0,
            "wheelbase_m": self_wheelbase(config),
            "max_steer_rad": 0.593,
        }
        driver = InputConfig(backend="sim", options={"mode": "path", "path": route})
        return msgspec.structs.replace(
            config, input=driver, ffb=FfbConfig(backend="sim"), motion=MotionConfig(backend="sim")
        )

    # ------------------------------------------------------------ lifecycle

    def start(self, session: str, node_id: str, offset: float) -> None:
        """Create the shared blocks and start the control process."""
        self._state = SharedBlock(block_name(session, node_id, "state"), STATE, create=True)
        self._control = SharedBlock(block_name(session, node_id, "control"), CONTROL, create=True)
        self._control.write_fields(clock_offset=offset)
        self._events, self._results = self._ctx.Queue(), self._ctx.Queue()
        self._stop = self._ctx.Event()
        spec = LoopSpec(self.config, self.vehicle, self._state.name, self._control.name)
        self._process = self._ctx.Process(
            target=run_loop,
            args=(spec, self._events, self._results, self._stop),
            name=f"{node_id}-loop",
            daemon=True,
        )
        self._process.start()

    def own_pose_block(self) -> OwnPoseBlock:
        """Where a view reads this car's pose without network delay (the loop's state)."""
        n = self.node_settings
        name = block_name(n.session, n.node_id, "state")
        return OwnPoseBlock(name, STATE, n.actor_kind, n.extent)

    def hmi_bridge(self) -> DriveHmiBridge:
        """The web HMI's view of this car (carlaverse join drive --hmi PORT)."""
        self._hmi = DriveHmiBridge(self.node_settings, self.vehicle, lambda: self._state)
        return self._hmi

    def pose_source(self) -> PoseSource | None:
        def source(t: float) -> Pose | None:
            if self._state is None:
                return None
            s = self._state.read()
            if not s["running"]:
                return None
            return Pose(
                0,
                float(s["t"]),
                float(s["x"]),
                float(s["y"]),
                0.0,
                0.0,
                0.0,
                float(s["yaw"]),
                float(s["vx"]),
                float(s["vy"]),
                0.0,
                0.0,
                0.0,
                float(s["yaw_rate"]),
                float(s["ax"]),
                float(s["ay"]),
                0.0,
            )

        return source

    def step(self, client: NodeClient, now: float) -> None:
        if self._process is None:
            self.start(client.settings.session, client.node_id, client.clock.offset)
        assert self._control is not None and self._state is not None
        self._control.write_fields(clock_offset=client.clock.offset)
        self._place_at_spawn(client)
        while client.impulses:
            self._events.put(client.impulses.popleft())
            self._forwarded += 1
        while client.overrides:
            self._events.put(client.overrides.popleft())
            self._forwarded += 1
        state = self._state.read()
        if self._hmi is not None:
            self._hmi.clock_offset = client.clock.offset
            self._forwarded += self._hmi.forward(self._events, now, float(state["speed_mps"]))
        self._publish_state(client, state)
        if not self._process.is_alive():
            raise RuntimeError(f"the control loop process died (exit {self._process.exitcode})")

    def _place_at_spawn(self, client: NodeClient) -> None:
        reply = client.join_reply
        if reply is None or reply.spawn is None or client.joins == self._joins_seen:
            return
        self._joins_seen = client.joins
        if self._spawn_seq:  # a re-join keeps the car where it is
            return
        self._spawn_seq += 1
        sp = reply.spawn
        self._control.write_fields(
            spawn_seq=self._spawn_seq,
            spawn_x=sp.x,
            spawn_y=sp.y,  # type: ignore[union-attr]
            spawn_yaw=sp.yaw,
        )

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
                key[2],  # type: ignore[arg-type]
                float(s["speed_mps"]),
                "adas" if key[3] else "",
            )
        )

    def close(self) -> None:
        if self._process is None:
            return
        self._loop_summary = stop_loop_process(
            self._process, self._stop, self._results, (self._state, self._control), "control loop"
        )

    def report(self) -> dict[str, Any]:
        return {"loop": self._loop_summary, "events_forwarded": self._forwarded}


def self_wheelbase(config: DriveNodeConfig) -> float:
    """The pure-pursuit driver needs the car's wheelbase [m]."""
    return float(resolve_vehicle(config).body.wheelbase_m)
