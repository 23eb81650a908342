"""The walk node as a `carlaverse join` kind: the fabric side of WalkoCARLA.

This process owns the fabric; the control loop (headset, controllers, walking) runs in a child
process (`loop_process`). The pose publisher reads the loop's shared state at the pose rate and
sends it as a `pedestrian` (the authority carries walkers into SUMO as persons, so NPC cars
yield to them at crossings). The node's step hands the loop the clock offset and the spawn
pose, sends it the walkable lanes of the map when `lanes.snap` is on (fetched from the
authority in a thread), and publishes the body's joints from the skeleton source (`body:`)
through its node client (`NodeClient.publish_skeleton`, on `ego/<id>/skeleton`).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import queue
import threading
from typing import Any

import msgspec
from carlaverse_nodes.loop_host import LoopHost
from carlaverse_nodes.walk.body import check_body, open_skeleton_source
from carlaverse_nodes.walk.config import WalkNodeConfig, node_settings
from carlaverse_nodes.walk.loop_process import WalkLoopSpec, run_walk_loop
from carlaverse_nodes.walk.shared_state import CONTROL, STATE
from carlaverse_nodes.walk.walkable import Walkable

from carlaverse import messages as m
from carlaverse.body.skeleton import SkeletonSource
from carlaverse.hal import XrConfig, xr
from carlaverse.hal.errors import HalError
from carlaverse.shm import block_name
from carlaverse.shm_layouts import OwnPoseBlock
from carlaverse.transport.node_client import NodeClient

log = logging.getLogger(__name__)

EYES_PART = "eyes"  # the block of the view's rendered eyes, for a headset that shows them

SIM_SCRIPT = [  # the headless walker of `--backend sim`: stroll, look around, jog, stop
    {"t": 0.0, "axes": {"move_y": 0.0}},
    {"t": 1.0, "axes": {"move_y": 1.0}},
    {"t": 8.0, "axes": {"move_y": 1.0, "move_x": 0.0}, "buttons": {"run": True}},
    {"t": 12.0, "axes": {"move_y": 0.6, "move_x": 0.4}, "buttons": {"run": False}},
    {"t": 20.0, "axes": {"move_y": 0.0, "move_x": 0.0}},
]
SIM_DISPLAY = [640, 640]  # [px] per eye: the sim headset takes the view's eyes at this size
SIM_EYES = {  # what a runtime reports for a typical headset [deg]: wider outwards
    "left": {"left_deg": -52.0, "right_deg": 42.0, "up_deg": 46.0, "down_deg": -50.0},
    "right": {"left_deg": -42.0, "right_deg": 52.0, "up_deg": 46.0, "down_deg": -50.0},
}


def preflight_headset(cfg: XrConfig) -> None:
    """Fail here, in one line, when the headset cannot work (no pyopenxr, no runtime)."""
    try:
        backend = xr.registry().resolve(cfg.backend)
        check = getattr(backend, "preflight", None)
        if check is not None:
            check()
    except HalError as exc:
        raise ValueError(str(exc)) from exc


class WalkNode(LoopHost):
    name = "walk"
    config_type = WalkNodeConfig

    def __init__(self, config: WalkNodeConfig) -> None:
        preflight_headset(config.xr)
        check_body(config.body)
        super().__init__(STATE, CONTROL, "walk loop")
        self.config = config
        self.node_settings = node_settings(config)
        self._lanes_join = 0  # the join whose map was asked for
        self._walkable_segments: int | None = None
        self._body: SkeletonSource | None = open_skeleton_source(config.body)
        self._skeletons_sent = 0

    @staticmethod
    def check_config(config: WalkNodeConfig) -> None:
        """What `config validate` checks beyond the schema: the body source and its options."""
        check_body(config.body)

    @classmethod
    def with_backend(cls, config: WalkNodeConfig, backend: str) -> WalkNodeConfig:
        """Every device simulated: a standing walker strolls, jogs and looks around."""
        if backend != "sim":
            raise ValueError(f"--backend {backend!r}: the walk node can force only 'sim'")
        options = {"posture": "standing", "script": SIM_SCRIPT, "yaw_amplitude_rad": 0.3,
                   "eyes": SIM_EYES, "display": SIM_DISPLAY}  # fmt: skip
        headset = XrConfig(backend="sim", options=options)
        return msgspec.structs.replace(config, xr=headset, input=None)

    def start(self, session: str, node_id: str, offset: float) -> None:
        eyes = block_name(session, node_id, EYES_PART)
        spec = functools.partial(WalkLoopSpec, self.config, eye_images=eyes)
        self._start_loop(session, node_id, run_walk_loop, spec, clock_offset=offset)

    def own_pose_block(self) -> OwnPoseBlock:
        """The loop's state, and where the view puts the eyes for a headset that shows them."""
        n = self.node_settings
        eyes = block_name(n.session, n.node_id, EYES_PART)
        return dataclasses.replace(super().own_pose_block(), eye_images=eyes)

    def step(self, client: NodeClient, now: float) -> None:
        self._tend_loop(client)
        self._follow_lanes(client)
        self._publish_skeleton(client)
        self._forward(client.impulses)
        if not self._process.is_alive():
            raise ValueError(f"the walk loop stopped: {self._loop_error()}")

    def _loop_error(self) -> str:
        try:
            report = self._results.get(timeout=1.0)
        except queue.Empty:
            return f"exit code {self._process.exitcode}"
        self._loop_summary = report
        return str(report.get("error", f"exit code {self._process.exitcode}"))

    def _follow_lanes(self, client: NodeClient) -> None:
        """With snapping on, ask each authority joined for its map; the loop gets the lanes."""
        if not self.config.lanes.snap or client.joins == self._lanes_join:
            return
        self._lanes_join = client.joins
        fetch = threading.Thread(target=self._fetch_lanes, args=(client,), daemon=True)
        fetch.start()  # the query waits on the authority: never in the step

    def _fetch_lanes(self, client: NodeClient) -> None:
        raw = client.query("map")
        if raw is None:
            log.warning("no map from the authority: the walker is not kept on walkable lanes")
            return
        try:
            walkable = Walkable.from_map(m.MAP.decode(raw), self.config.lanes)
        except m.MessageError as exc:
            log.warning("map unusable, the walker is not kept on walkable lanes: %s", exc)
            return
        self._walkable_segments = len(walkable)
        self._events.put(walkable.to_arrays())

    def _publish_skeleton(self, client: NodeClient) -> None:
        """The body's newest joints, on session time with the node's sequence (`body.py`)."""
        if self._body is None:
            return
        skeleton = self._body.poll()
        if skeleton is not None and client.publish_skeleton(skeleton):
            self._skeletons_sent += 1

    def close(self) -> None:
        if self._body is not None:
            try:
                self._body.close()
            except Exception:  # closing must not hide the summary; log it
                log.exception("closing the skeleton source failed")
            self._body = None
        self._stop_loop()

    def report(self) -> dict[str, Any]:
        return {"loop": self._loop_summary, "skeletons_sent": self._skeletons_sent,
                "walkable_segments": self._walkable_segments}  # fmt: skip
